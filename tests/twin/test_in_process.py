"""The node in this process, ticked by hand (no peers needed): recording hook, sim-time stamps,
an exception inside a handler that must not escape, parameter changes."""
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
    assert node.now_ns() == node.arms.sim_ns == 3 * 10_000_000


def test_handler_exception_is_reported_not_raised(make_node):
    node = make_node()
    refused = []
    node._refuse = lambda env, kind, text, level="error": refused.append(text)
    node.arms.state_command(0, "enable")
    node.arms.state_command(0, "home")
    while not node.arms.states[0].is_homed:
        node._tick()
    sub = next(sub for sub in node._command_subs if sub.topic_name == "/PSM1/servo_jp")
    sub.callback(object(), {})  # not a JointState: the handler raises inside
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
    assert node.arms.period_ns == 20_000_000 and node.arms.bodies.engine.physics.substeps == 4
    results = node.set_parameters([Parameter("sensors", value=["joints", "jacobian"])])
    assert results[0].successful and "body/jacobian" in node.sensor_pubs[0][0]
    results = node.set_parameters([Parameter("arm", value="PSM2")])
    assert not results[0].successful and "restart" in results[0].reason
    node._tick()
    assert node.arms.sim_ns == 20_000_000
