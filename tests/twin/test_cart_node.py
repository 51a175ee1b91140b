"""The patient cart's node in this process, ticked by hand: every arm under its dVRK namespace,
the stereo camera_info, the ECM's state machine and motion."""
import numpy as np
import pytest

from cressim.twin import JointCommand
from cressim.twin.cart import pairs

pytestmark = pytest.mark.ros


def test_cart_node_namespaces_stereo_and_ecm(make_node):
    from cressim_ros.twin_node import _transform

    node = make_node(scene="patient_cart.yaml")
    topics = {name for name, _ in node.get_topic_names_and_types()}
    for arm in ("/PSM1", "/PSM2", "/ECM"):
        for topic in ("measured_js", "setpoint_js", "measured_cp", "operating_state", "state_command", "servo_jp"):
            assert f"{arm}/{topic}" in topics, f"{arm}/{topic}"
    for eye in ("left", "right"):
        for product in ("color", "depth", "segmentation"):
            assert f"/camera/{eye}/{product}/image_raw" in topics and f"/camera/{eye}/{product}/camera_info" in topics
        assert f"/camera/{eye}/color/image_raw/compressed" in topics
        assert f"/camera/{eye}/depth/image_raw/compressedDepth" in topics
    for arm in ("MTML", "MTMR"):
        for topic in ("measured_cp", "gripper/measured_js", "operating_state", "move_cp", "lock_orientation"):
            assert f"/{arm}/{topic}" in topics, f"{arm}/{topic}"
    assert {"/footpedals/clutch", "/footpedals/camera", "/console/operator_present", "/operator/present",
            "/operator/MTMR/servo_cp"} <= topics
    # each arm as robot_state_publisher would give it, under its own name
    assert {"/PSM1/robot_description", "/PSM2/robot_description", "/ECM/robot_description", "/PSM1/joint_states",
            "/ECM/joint_states"} <= topics
    psm2 = node.robot_states[0].descriptions[1].data  # the PSMs' (one FK for both), row PSM2
    assert "<robot" in psm2 and "PSM2_shaft_link" in psm2 and "PSM1_" not in psm2
    left, right = node.camera.infos
    fx = left.p[0]
    assert left.p[3] == 0.0 and right.p[3] == pytest.approx(-fx * 0.005)  # ROS: Tx = -fx B (the scene's baseline)
    # PSM2 moves alone; the ECM follows its state machine and a move_jp
    node._on_console("enable", None)
    node._on_console("home", None)
    cart = node.cart
    while any(arm.states[0].is_busy for arm in cart.psms) or cart.ecm.states[0].is_busy:
        node._tick()
    assert cart.ecm.states[0].is_homed and all(arm.states[0].is_homed for arm in cart.psms)
    node._emit(cart.servo_jp(1, JointCommand(position=[0.2, 0.0, 0.11, 0.0, 0.0, 0.0])))
    node.ecm.emit(pairs(cart.ecm.move_jp(0, JointCommand(position=[0.1, 0.05, 0.06, -1.4]))))
    for _ in range(100):
        node._tick()
    assert cart.psms[1].measured[0, 0] == pytest.approx(0.2, abs=1e-3)
    assert cart.psms[0].measured[0, 0] == pytest.approx(0.0, abs=1e-9)
    assert np.allclose(cart.ecm.measured[0], [0.1, 0.05, 0.06, -1.4], atol=1e-3)
    links = {(t.header.frame_id, t.child_frame_id) for rs in node.robot_states
             for t in rs.publish(node.stamp(), _transform)}
    assert ("PSM2_pitch_front_link", "PSM2_insertion_link") in links and ("ECM_base", "ECM_yaw_link") in links
    frames = {(t.header.frame_id, t.child_frame_id) for t in node.static_tf.transforms}
    assert {("world", "PSM1_base"), ("world", "PSM2_base"), ("world", "ECM_base"),
            ("ECM", "camera_left_optical_frame"), ("ECM", "camera_right_optical_frame")} <= frames


def test_cart_recording_holds_every_arm(make_node, tmp_path):
    import yaml
    from crtk_msgs.msg import StringStamped
    from hand_ticked import client_beside
    from std_msgs.msg import Float64MultiArray

    from cressim.record import read_messages

    bag = tmp_path / "bag"
    node = make_node(scene="patient_cart.yaml", record=str(bag))
    for _ in range(10):
        node._tick()
    # a client's command to the ECM, over DDS: the bag keeps it as it keeps the PSMs' commands
    with client_beside(node, "cart_recording_client") as (client, until):
        ecm = client.create_publisher(StringStamped, "/ECM/state_command", 10)
        until(lambda: ecm.get_subscription_count() > 0, "the twin does not listen on /ECM/state_command")
        ecm.publish(StringStamped(string="enable"))
        until(lambda: node.cart.ecm.states[0].state == "ENABLED", "the ECM's enable did not arrive")
    # a console command, as its subscription hands it over
    next(sub for sub in node._command_subs if sub.topic_name == "/system/beep").callback(
        Float64MultiArray(data=[0.2, 1000.0, 0.5]))
    ticks = node.arms.ticks  # 10, and those the waits above ticked
    node.close()
    meta = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    counts = {t["topic_metadata"]["name"]: t["message_count"] for t in meta["topics_with_message_count"]}
    for topic in ("/PSM1/measured_js", "/PSM2/measured_cp", "/ECM/measured_js", "/ECM/measured_cp",
                  "/MTMR/measured_cp", "/MTML/gripper/measured_js"):
        assert counts.get(topic) == ticks, (topic, counts.get(topic), ticks)  # a sample a tick
    for topic in ("/ECM/operating_state", "/MTMR/operating_state", "/footpedals/clutch", "/PSM2/robot_description",
                  "/camera/left/color/image_raw", "/camera/right/color/camera_info"):
        assert counts.get(topic, 0) >= 1, topic
    commands = [msg.string for _, msg in read_messages(bag, "/ECM/state_command", decode=True)]
    assert commands == ["enable"], commands  # once, whichever of the ECM's readers passed it
    assert counts.get("/system/beep") == 1 and node.console_commands == {"beep": 1}


def test_cart_coag_pedal_is_heard_and_refused_with_reasons(make_node):
    """The cart's console has the dVRK's coagulation pedal, /footpedals/coag (one for the cart, not
    one per PSM): a press over DDS reaches every PSM, and the cart's needle drivers over a world
    without heat-taking tissue each refuse it on their `error`, saying why; counted once each."""
    from rclpy.qos import DurabilityPolicy, QoSProfile
    from sensor_msgs.msg import Joy
    from std_msgs.msg import String

    from hand_ticked import client_beside

    node = make_node(scene="patient_cart.yaml", sensors=["joints"])
    node.timer.cancel()
    topics = {name for name, _ in node.get_topic_names_and_types()}
    assert "/footpedals/coag" in topics and not [t for t in topics if t.endswith("/footpedals/coag") and
                                                t != "/footpedals/coag"], sorted(topics)
    with client_beside(node, "cart_pedal_client") as (client, until):
        errors = {arm: [] for arm in ("PSM1", "PSM2")}
        for arm, got in errors.items():
            client.create_subscription(String, f"/{arm}/error", got.append,
                                       QoSProfile(depth=10, durability=DurabilityPolicy.TRANSIENT_LOCAL))
        pedal = client.create_publisher(Joy, "/footpedals/coag", 10)
        until(lambda: pedal.get_subscription_count() > 0, "the cart does not listen on /footpedals/coag")
        pedal.publish(Joy(buttons=[1]))
        until(lambda: all(errors.values()), f"no refusal on every PSM's error: {errors}")
    for arm, got in errors.items():
        assert [m.data for m in got] == [f"{arm}: footpedals/coag refused: the world has no tissue that takes heat "
                                         "(a soft_body with thermal)"], got
    assert {key: n for key, n in node.refusals.items() if key[1] == "footpedals/coag"} == \
        {(0, "footpedals/coag"): 1, (1, "footpedals/coag"): 1}
