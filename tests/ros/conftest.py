"""ROS 2 tests: real rclpy nodes talking over DDS (Fast DDS) on loopback.

How the environment is set up
-----------------------------
The ROS 2 Jazzy runtime comes from PyPI wheels installed into a virtualenv (rclpy, Fast DDS and
the common message packages); our own message package crtk_msgs is built from
ros_ws/src/crtk_msgs with colcon into ros_ws/install by::

    ros_ws/build.sh [VENV]          # VENV: the project's .venv (make), or .venv-ros by default
    source ros_ws/env.sh            # PATH, PYTHONPATH, LD_LIBRARY_PATH, AMENT_PREFIX_PATH
    python -m pytest tests/ros

env.sh must be sourced *before* Python starts: the generated crtk_msgs typesupport libraries
are located through LD_LIBRARY_PATH (rosidl_typesupport_c searches it by file name), which the
dynamic loader reads only at process start, so this conftest cannot fix it up at run time.
(The wheels' ros_wheels_bootstrapper .pth re-execs the interpreter once to add the venv's own
library dirs; it keeps what env.sh put there.)

What happens here
-----------------
* rclpy not importable -> every test in tests/ros is skipped, with the reason.
* rclpy importable but crtk_msgs missing or its libraries not on LD_LIBRARY_PATH -> the tests
  fail with a message saying to run ros_ws/build.sh and source ros_ws/env.sh.
* Every test gets its own ROS_DOMAIN_ID (fixture ``ros_domain_id``, derived from the pid and a
  counter) and ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST, so parallel runs do not hear each other.
"""
import itertools
import os

import pytest

WS = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))),
                  "ros_ws")
HOWTO = ("run `ros_ws/build.sh [VENV]` once, then `source ros_ws/env.sh` in the shell that "
         "runs pytest (see tests/ros/conftest.py)")

try:
    import rclpy  # noqa: F401
    RCLPY_ERROR = None
except ImportError as exc:  # also catches a missing shared library of the wheels
    RCLPY_ERROR = f"rclpy not importable ({exc}); install the ROS 2 wheels: {HOWTO}"


def crtk_env_problem():
    """None when crtk_msgs can be used in this process, else what is wrong and how to fix it."""
    try:
        import crtk_msgs.msg  # noqa: F401
    except ImportError as exc:
        return f"crtk_msgs not importable ({exc}): {HOWTO}"
    lib = "libcrtk_msgs__rosidl_typesupport_c.so"
    dirs = [d for d in os.environ.get("LD_LIBRARY_PATH", "").split(os.pathsep) if d]
    if not any(os.path.exists(os.path.join(d, lib)) for d in dirs):
        return f"{lib} is not in any LD_LIBRARY_PATH directory: {HOWTO}"
    return None


def pytest_collection_modifyitems(config, items):
    if RCLPY_ERROR is None:
        return
    here = os.path.dirname(os.path.abspath(__file__))
    mark = pytest.mark.skip(reason=RCLPY_ERROR)
    for item in items:
        if str(item.fspath).startswith(here + os.sep):
            item.add_marker(mark)


@pytest.fixture(scope="session")
def crtk_env():
    problem = crtk_env_problem()
    if problem:
        pytest.fail(problem, pytrace=False)


_ids = itertools.count()


def pick_domain(n: int) -> int:
    """The n-th ROS_DOMAIN_ID of this process: within CRESSIM_TEST_DOMAINS ("LO-HI", default 1-100;
    Fast DDS ports stay below the ephemeral range), where `make test`'s concurrent pytest runs each
    get a range of their own, and keyed by the pid so that runs of the same range rarely meet."""
    lo, hi = (int(x) for x in os.environ.get("CRESSIM_TEST_DOMAINS", "1-100").split("-"))
    return lo + (os.getpid() * 7 + n) % (hi - lo + 1)


@pytest.fixture
def ros_domain_id(monkeypatch, crtk_env):
    """A ROS_DOMAIN_ID of this test alone (pick_domain), exported so that subprocesses inherit it;
    discovery kept on localhost."""
    domain = pick_domain(next(_ids))
    monkeypatch.setenv("ROS_DOMAIN_ID", str(domain))
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    monkeypatch.delenv("ROS_LOCALHOST_ONLY", raising=False)
    monkeypatch.delenv("ROS_STATIC_PEERS", raising=False)
    return domain
