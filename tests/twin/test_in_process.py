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


def test_forward_kinematics_service_equals_the_urdf_model(make_node):
    """The forward_kinematics services over DDS, for 1,000 random joint vectors, against the URDF
    chain (cressim.robots.PSM); local/ is in the RCM frame, the other in the base frame."""
    import numpy as np
    import torch
    from crtk_msgs.srv import QueryForwardKinematics
    from rclpy.executors import MultiThreadedExecutor

    from cressim.robots import PSM, pose7_to_matrix
    from twin_fixtures import spinning

    node = make_node()
    node.timer.cancel()  # services only: no ticks on the executor's threads
    with spinning(node, "fk_client", MultiThreadedExecutor) as client_node:
        urdf = PSM(node.arms.psm.urdf_path, dtype=torch.float64)
        q = np.random.default_rng(3).uniform(node.arms.kin.lower_np, node.arms.kin.upper_np, size=(1000, 6))
        expected = urdf.forward_kinematics(torch.as_tensor(q)).numpy()
        clients = {name: client_node.create_client(QueryForwardKinematics, f"/PSM1/{name}")
                   for name in ("local/forward_kinematics", "forward_kinematics")}
        for c in clients.values():
            assert c.wait_for_service(timeout_sec=60)
        for k in range(1000):
            name = "local/forward_kinematics" if k % 2 else "forward_kinematics"  # base frame = RCM here
            response = clients[name].call(QueryForwardKinematics.Request(jp=list(q[k])), timeout_sec=60)
            assert response.result, response.message
            p, o = response.cp.position, response.cp.orientation
            T = pose7_to_matrix(np.array([p.x, p.y, p.z, o.x, o.y, o.z, o.w]))
            assert np.abs(T - expected[k]).max() < 1e-6, (k, T, expected[k])
        bad = clients["forward_kinematics"].call(QueryForwardKinematics.Request(jp=[0.0] * 5), timeout_sec=60)
        assert not bad.result and "expected 6" in bad.message


def test_diagnostics_are_published(make_node):
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.executors import SingleThreadedExecutor

    node = make_node(camera_rate=100.0)
    client = rclpy.create_node("diagnostics_client", context=node.context)
    got = []
    client.create_subscription(DiagnosticArray, "/diagnostics", got.append, 10)
    executor = SingleThreadedExecutor(context=node.context)
    executor.add_node(client)
    try:
        for _ in range(200):
            if got:
                break
            node._next_diagnostics = 0.0  # due every tick here, not once a second
            node._tick()
            executor.spin_once(timeout_sec=0.05)
        assert got, "no /diagnostics"
        status = {s.name: {kv.key: kv.value for kv in s.values} for s in got[-1].status}
        assert {"cressim_twin: tick", "cressim_twin: camera", "cressim_twin: commands"} <= set(status)
        assert float(status["cressim_twin: tick"]["target rate (Hz)"]) == 100.0, status
    finally:
        executor.shutdown()
        client.destroy_node()


def test_robot_description_joint_states_and_link_tf(make_node):
    """What robot_state_publisher would give, so RViz shows the arm: the URDF latched, every URDF
    joint (mimics included) on /joint_states, each link on /tf from its parent."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import DurabilityPolicy, QoSProfile
    from sensor_msgs.msg import JointState
    from std_msgs.msg import String
    from tf2_msgs.msg import TFMessage

    node = make_node(arm="PSM2")
    client = rclpy.create_node("rviz_like", context=node.context)
    got = {"description": [], "joints": [], "tf": []}
    client.create_subscription(String, "/robot_description", got["description"].append,
                               QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL))
    client.create_subscription(JointState, "/joint_states", got["joints"].append, 10)
    client.create_subscription(TFMessage, "/tf", got["tf"].append, 10)
    executor = SingleThreadedExecutor(context=node.context)
    executor.add_node(client)
    try:
        for _ in range(200):
            if all(got.values()):
                break
            node._tick()
            executor.spin_once(timeout_sec=0.05)
        assert all(got.values()), {k: len(v) for k, v in got.items()}
        text = got["description"][0].data
        assert "PSM2_base" in text and "PSM1_" not in text  # the arm's name, as its frames on /tf_static
        names = set(got["joints"][-1].name)
        assert {"yaw", "pitch", "pitch_top", "pitch_front", "pitch_bottom", "insertion", "jaw_1", "jaw_2"} <= names
        pairs = {(t.header.frame_id, t.child_frame_id) for t in got["tf"][-1].transforms}
        assert ("PSM2_base", "PSM2_mount_link") in pairs and ("PSM2_wrist_yaw_link", "PSM2_jaw_link") in pairs
    finally:
        executor.shutdown()
        client.destroy_node()
