"""Tests of the ROS 2 twin (ros_ws/src/cressim_ros): real rclpy over DDS on loopback.

Run after `ros_ws/build.sh` with `source ros_ws/env.sh && .venv/bin/python -m pytest tests/twin`.
The twin runs as a subprocess (`python -m cressim_ros`, a DDS participant of its own) from the
source tree (ros_ws/src/cressim_ros first on PYTHONPATH, so an older colcon install does not
shadow it); test clients run in this process on a context of their own. Each twin gets its own
ROS_DOMAIN_ID: the `ros_domain_id` fixture of tests/ros for a twin per test, `twin_domain` (same
scheme, other ids) for a twin shared by a module. Without rclpy every test needing it is skipped
(tests/ros/conftest.py says how to set it up); the unit tests of the node's pure-Python parts run.
"""
import importlib.util
import itertools
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
PKG = REPO / "ros_ws" / "src" / "cressim_ros"
sys.path.insert(0, str(PKG))  # cressim_ros from the source tree
sys.path.insert(0, str(Path(__file__).resolve().parent))  # twin_fixtures

from cressim_ros.twin_process import Twin  # noqa: E402
from twin_fixtures import TEST_CAMERA, clients_folder  # noqa: E402

# reuse tests/ros's environment checks and its ros_domain_id fixture (one implementation)
_spec = importlib.util.spec_from_file_location("_cressim_tests_ros_conftest", REPO / "tests" / "ros" / "conftest.py")
_ros = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_ros)
crtk_env = _ros.crtk_env
ros_domain_id = _ros.ros_domain_id
RCLPY_ERROR = _ros.RCLPY_ERROR

_module_ids = itertools.count(50)  # twin_domain's ids sit 50 away from ros_domain_id's


def pytest_collection_modifyitems(config, items):
    if RCLPY_ERROR is None:
        return
    mark = pytest.mark.skip(reason=RCLPY_ERROR)
    for item in items:
        if item.get_closest_marker("ros") is not None:
            item.add_marker(mark)


def pytest_configure(config):
    config.addinivalue_line("markers", "ros: needs rclpy and crtk_msgs (skipped without rclpy)")


@pytest.fixture(scope="module")
def twin_domain():
    """A ROS_DOMAIN_ID for a twin shared by one test module (ros_domain_id's scheme, 50 ids away)."""
    problem = _ros.crtk_env_problem() if RCLPY_ERROR is None else RCLPY_ERROR
    if problem:
        pytest.fail(problem, pytrace=False)
    return _ros.pick_domain(next(_module_ids))


@pytest.fixture
def start_twin(tmp_path):
    """start_twin(domain, *params) -> a ready Twin; stopped (and checked alive) at teardown."""
    twins = []

    def start(domain, *params):
        twin = Twin(domain, tmp_path / f"twin{len(twins)}.log", *TEST_CAMERA, *params)
        twins.append(twin)
        twin.startup_s = twin.wait_ready()
        return twin

    yield start
    for twin in twins:
        twin.stop()


@pytest.fixture
def make_arms():
    """make_arms(**config) -> cressim.twin.TwinArms (no ROS; 64x48 cameras), checked for Vulkan
    validation messages at teardown."""
    from cressim.twin import TwinArms, TwinConfig

    made = []

    def make(**config):
        arms = TwinArms(TwinConfig(**{"camera_width": 64, "camera_height": 48, **config}))
        made.append(arms)
        return arms

    yield make
    for arms in made:
        engine = arms.bodies.engine  # tests/conftest.py turns the Vulkan validation layer on
        assert engine.validation_messages == [], "\n".join(engine.validation_messages)


@pytest.fixture
def make_node(ros_domain_id):
    """make_node(**params) -> a TwinNode in this process (own rclpy context, ticked by hand with
    node._tick()); closed, checked for Vulkan validation messages and destroyed at teardown."""
    import rclpy
    from rclpy.context import Context
    from rclpy.parameter import Parameter

    from cressim_ros.twin_node import TwinNode

    context = Context()
    rclpy.init(context=context, domain_id=ros_domain_id)
    nodes = []

    def make(**params):
        params = {"camera_width": 64, "camera_height": 48, **params}
        node = TwinNode(context=context, threaded_sensors=False,
                        parameter_overrides=[Parameter(k, value=v) for k, v in params.items()])
        nodes.append(node)
        return node

    yield make
    for node in nodes:
        node.close()
        engine = node.arms.bodies.engine  # tests/conftest.py turns the Vulkan validation layer on
        assert engine.validation_messages == [], "\n".join(engine.validation_messages)
        node.destroy_node()
    rclpy.try_shutdown(context=context)


@pytest.fixture(scope="module")
def clients() -> Path:
    """The dVRK's Python clients' folder, checked: the tests that run them are skipped (with the
    folder named) where it is missing, and fail where PyKDL or CRTK messages are."""
    folder = clients_folder()
    needed = [folder / "crtk_python_client" / "src" / "crtk", folder / "dvrk_python" / "src" / "dvrk"]
    if not all(p.is_dir() for p in needed):
        pytest.skip(f"the dVRK's Python clients are not in {folder} (crtk_python_client/, dvrk_python/): "
                    "set CRESSIM_DVRK_CLIENTS to the folder that holds them")
    if importlib.util.find_spec("PyKDL") is None:
        pytest.fail("PyKDL is not importable in this Python: `make .make/pykdl` links Debian's "
                    "python3-pykdl into .venv (apt-get install python3-pykdl first)", pytrace=False)
    import crtk_msgs.msg
    if not hasattr(crtk_msgs.msg, "CartesianImpedance"):
        pytest.fail("crtk_msgs lacks CartesianImpedance (`import dvrk` needs every CRTK message): "
                    "rebuild ros_ws (`bash ros_ws/build.sh .venv`)", pytrace=False)
    return folder
