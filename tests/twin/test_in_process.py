"""The node in this process, ticked by hand (no peers needed): recording hook, sim-time stamps,
a suction tool without jaw, and an exception inside a handler that must not escape."""
import os

import pytest
import yaml

pytestmark = pytest.mark.ros


def test_recording_hook(make_node, tmp_path):
    bag = tmp_path / "bag"
    node = make_node(record=str(bag))
    for _ in range(20):
        node._tick()
    node.close()
    meta = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    counts = {t["topic_metadata"]["name"]: t["message_count"] for t in meta["topics_with_message_count"]}
    assert counts["/PSM1/measured_js"] == 20 and counts["/PSM1/operating_state"] >= 1
    assert not any(name.startswith("/env0/") for name in counts), "N = 1 is recorded once, under /PSM1"


def test_sim_time_stamps(make_node):
    node = make_node(use_sim_time=True)
    first = node.stamp()
    assert (first.sec, first.nanosec) != (0, 0)  # never zero, even before the first tick
    for _ in range(3):
        node._tick()
    assert node.now_ns() == node.sim_ns == 3 * 10_000_000


def test_suction_tool_refuses_jaw_and_wrist(make_node):
    from sensor_msgs.msg import JointState

    node = make_node(robot="psm_suction")
    node.states[0].command("enable")
    node.states[0].homing_done()
    refused = []
    node._refuse = lambda env, kind, text, level="error": refused.append(text)
    node._on_jaw_move_jp(0, JointState(position=[0.3]))
    node._on_servo_jp(0, JointState(position=[0.0, 0.0, 0.1, 0.0, 0.2, 0.0]))
    assert "no jaw" in refused[0] and "wrist_pitch" in refused[1] and "no such joint" in refused[1]
    node._on_servo_jp(0, JointState(position=[0.1, 0.0, 0.1, 0.5, 0.0, 0.0]))
    node._tick()
    assert float(node.setpoint[0, 3]) == 0.5 and len(refused) == 2


def test_handler_exception_is_reported_not_raised(make_node):
    node = make_node()
    refused = []
    node._refuse = lambda env, kind, text, level="error": refused.append(text)
    node._on_servo_jp(0, object())  # not a JointState: the handler raises inside
    assert refused and "internal error" in refused[0]
    node._tick()  # and the node goes on


def test_bad_record_path_at_start(make_node, tmp_path):
    from cressim_ros.twin_node import ConfigError

    with pytest.raises(ConfigError, match="does not exist"):
        make_node(record=os.path.join(str(tmp_path), "missing", "bag"))


def test_runtime_parameter_changes(make_node):
    from rclpy.parameter import Parameter

    node = make_node()
    results = node.set_parameters([Parameter("publish_rate", value=50.0)])
    assert results[0].successful, results[0].reason
    assert node.period_ns == 20_000_000 and node.bodies.engine.physics.substeps == 4
    results = node.set_parameters([Parameter("sensors", value=["joints", "jacobian"])])
    assert results[0].successful and "body/jacobian" in node.sensor_pubs[0][0]
    results = node.set_parameters([Parameter("arm", value="PSM2")])
    assert not results[0].successful and "restart" in results[0].reason
    node._tick()
    assert node.sim_ns == 20_000_000
