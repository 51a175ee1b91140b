"""`--ros-args --params-file`: the twin reads its parameters from a ROS 2 parameters file (as
`ros2 run ... --ros-args --params-file twin.yaml` or a launch file passes them)."""
import pytest

pytestmark = pytest.mark.ros

PARAMS = """\
cressim_twin:
  ros__parameters:
    arm: PSM2
    publish_rate: 50.0
    physics_rate: 100.0
    use_sim_time: true
    sensors: [joints, clock]
"""


def test_params_file(ros_domain_id, tmp_path):
    from cressim_ros.dvrk_client import Ral, _Latest
    from cressim_ros.twin_process import Twin
    from sensor_msgs.msg import JointState

    path = tmp_path / "twin.yaml"
    path.write_text(PARAMS)
    twin = Twin(ros_domain_id, tmp_path / "twin.log", params_file=path)
    ral = None
    try:
        twin.wait_ready()
        assert "as /PSM2, /env0/PSM2 at 50 Hz (physics 100 Hz" in twin.output()
        ral = Ral("params_client", ros_domain_id)
        js = _Latest(keep=20)
        ral.subscriber(JointState, "/PSM2/measured_js", js, 100)
        assert js.wait_for(lambda m: js.count >= 10, 60), "no /PSM2/measured_js"
        stamps = [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in js.history]
        # use_sim_time: stamps are the twin's simulated time, one 20 ms period per tick
        assert {b - a for a, b in zip(stamps, stamps[1:])} == {20_000_000}, stamps
    finally:
        if ral is not None:
            ral.shutdown()
        assert twin.stop() == 0, twin.output()


def test_docs_show_the_parameter_table():
    """docs/twin.md's parameter table is generated from the node's parameter specs."""
    from pathlib import Path

    from cressim.twin_scene_file import load_scene
    from cressim_ros import params

    repo = Path(__file__).resolve().parents[2]
    doc = (repo / "docs" / "twin.md").read_text()
    begin, end = doc.index("<!-- params:begin"), doc.index("<!-- params:end -->")
    table = doc[doc.index("\n", begin) + 1:end]
    expected = params.markdown(load_scene(str(repo / "scenes" / "psm_twin.yaml")))
    assert table.strip() == expected.strip(), "regenerate it: cressim_ros.params.markdown(scene)"


BAD = """\
/**:
  ros__parameters:
    robot_description: "<robot/>"   # another node's: not the twin's to refuse
cressim_twin:
  ros__parameters:
    arm: PSM2
    num_envs: two
"""


def _where(text: str, line: int, token: str) -> str:
    """line:column (1-based) of `token` on 1-based `line` of `text`, as the YAML reads."""
    return f"{line}:{text.splitlines()[line - 1].index(token) + 1}"


def test_a_bad_value_in_a_params_file_names_file_line_and_column(tmp_path):
    from cressim.twin import ConfigError
    from cressim_ros import params

    path = tmp_path / "twin.yaml"
    path.write_text(BAD)
    with pytest.raises(ConfigError) as info:
        params.check_params_files(["cressim_twin", "--ros-args", "--params-file", str(path)])
    assert str(info.value) == (f"{path}:{_where(BAD, 7, 'two')}: cressim_twin.ros__parameters.num_envs: "
                               "expected an integer, got 'two'")
    path.write_text(BAD.replace("num_envs: two", "num_env: 2"))  # a misspelt name rclpy would ignore
    with pytest.raises(ConfigError, match=rf"{path}:{_where(BAD, 7, 'num_envs')}: cressim_twin.ros__parameters."
                                          r"num_env: unknown field 'num_env'; .* \(did you mean 'num_envs'\?\)"):
        params.check_params_files(["--ros-args", "--params-file", str(path)])
    path.write_text(PARAMS)
    params.check_params_files(["--ros-args", "--params-file", str(path)])  # a good file passes


def test_the_node_refuses_a_bad_params_file_with_its_place(ros_domain_id, tmp_path):
    from cressim_ros.twin_process import Twin

    path, text = tmp_path / "twin.yaml", BAD.replace("num_envs: two", "publish_rate: -5.0")
    path.write_text(text)
    twin = Twin(ros_domain_id, tmp_path / "twin.log", params_file=path)
    twin.proc.wait(timeout=120)  # it stops by itself, before building anything
    assert twin.stop() == 2, twin.output()
    assert (f"not started: {path}:{_where(text, 7, '-5.0')}: cressim_twin.ros__parameters.publish_rate: "
            "-5 Hz is outside (0, 2000]") in twin.output(), twin.output()
