"""Replay: tracking error on synthetic data with known answers, command loading, timing with a
fake clock, the CLI end to end (--loopback), and the rclpy link against a stand-in twin."""
import json
import threading

import numpy as np
import pytest

from cressim.record import BagWriter, read_messages
from cressim.record import types as T
from cressim.record.cli import main as record_cli
from cressim.record.replay import (Command, JointSample, LoopbackTwin, command_reference, format_errors,
                                   joint_positions, load_commands, prepend_enable, replay, restamp,
                                   tracking_error)
from cressim.record.schema import ARM_JOINTS, JAW_JOINTS
from cressim.record.synthetic import HOME

JS = "sensor_msgs/msg/JointState"


def samples(group, times, positions):
    return [JointSample(t, group, np.asarray(q, dtype=float)) for t, q in zip(times, positions)]


def test_tracking_error_of_a_constant_offset_and_a_step_response():
    t_ref = np.arange(0, 1.0, 0.01)
    q_ref = np.stack([np.sin(t_ref + j) for j in range(6)], axis=1)
    offset = np.array([0.01, -0.02, 0.001, 0.0, 0.05, -0.05])
    ref = {ARM_JOINTS: samples(ARM_JOINTS, t_ref, q_ref)}
    # measured exactly at the reference times: zoh == linear == the offset
    meas = {ARM_JOINTS: samples(ARM_JOINTS, t_ref, q_ref + offset)}
    for hold in ("zoh", "linear"):
        err = tracking_error(ref, meas, hold=hold)
        for j, name in enumerate(ARM_JOINTS):
            assert err[name]["rms"] == pytest.approx(abs(offset[j]), abs=1e-12)
            assert err[name]["mean"] == pytest.approx(offset[j], abs=1e-12)
            assert err[name]["max_abs"] == pytest.approx(abs(offset[j]), abs=1e-12)
            assert err[name]["n"] == len(t_ref)
    assert err["insertion"]["unit"] == "m" and err["yaw"]["unit"] == "rad"
    # a step of 1 at t=0.5 tracked with a 0.1 s delay: zoh error is -1 for 10 of 100 samples
    t = np.arange(0, 1.0, 0.01)
    step = (t >= 0.5 - 1e-9).astype(float)
    late = (t >= 0.6 - 1e-9).astype(float)
    ref = {JAW_JOINTS: samples(JAW_JOINTS, t, step[:, None])}
    meas = {JAW_JOINTS: samples(JAW_JOINTS, t, late[:, None])}
    err = tracking_error(ref, meas)["jaw"]
    assert err["max_abs"] == 1.0 and err["mean"] == pytest.approx(-0.1) and err["rms"] == pytest.approx(np.sqrt(0.1))
    assert err["final"] == 0.0
    assert "jaw" in format_errors({"jaw": err})


def test_tracking_error_windows_zoh_and_missing_joints():
    ref = {ARM_JOINTS: samples(ARM_JOINTS, [1.0, 2.0], [[1.0] * 6, [2.0] * 6])}
    q = np.full((5, 6), 1.5)
    q[:, 3] = np.nan  # a measured message without 'roll'
    meas = {ARM_JOINTS: samples(ARM_JOINTS, [0.0, 1.0, 1.5, 2.0, 2.5], q)}
    err = tracking_error(ref, meas)  # the sample at t=0 precedes the reference: ignored
    assert err["yaw"]["n"] == 4 and err["yaw"]["mean"] == pytest.approx((0.5 + 0.5 - 0.5 - 0.5) / 4)
    assert "roll" not in err
    lin = tracking_error(ref, meas, hold="linear")  # within the reference span only: t=1, 1.5, 2
    assert lin["yaw"]["n"] == 3 and lin["yaw"]["max_abs"] == pytest.approx(0.5)
    assert lin["pitch"]["rms"] == pytest.approx(np.sqrt((0.25 + 0 + 0.25) / 3))
    assert tracking_error(ref, meas, t_min=1.9)["yaw"]["n"] == 2
    assert tracking_error({}, meas) == {}


def test_joint_positions_by_name_old_names_and_order():
    msg = {"name": ["outer_pitch", "yaw", "bogus"], "position": [0.2, 0.1, 9.0]}
    q = joint_positions(msg, ARM_JOINTS)
    assert q[0] == 0.1 and q[1] == 0.2 and np.isnan(q[2:]).all()
    assert list(joint_positions({"name": [], "position": [1, 2, 3, 4, 5, 6]}, ARM_JOINTS)) == [1, 2, 3, 4, 5, 6]
    assert list(joint_positions({"name": ["jaw"], "position": [0.3]}, JAW_JOINTS)) == [0.3]


def _write_bag(path, with_servo=True):
    t0 = 1_700_000_000_000_000_000
    with BagWriter(path) as w:
        w.write("/PSM1/state_command", {"string": "enable"}, msgtype="crtk_msgs/msg/StringStamped", log_time=t0)
        for k in range(10):
            t = t0 + (k + 1) * 10_000_000
            q = [0.01 * k] * 6
            if with_servo:
                w.write("/PSM1/servo_jp", {"position": q}, msgtype=JS, log_time=t)  # no names: arm order
            w.write("/PSM1/setpoint_js", {"name": list(ARM_JOINTS), "position": q}, msgtype=JS, log_time=t + 1)
            w.write("/PSM1/measured_js", {"name": list(ARM_JOINTS), "position": q}, msgtype=JS, log_time=t + 2)
        w.write("/PSM2/servo_jp", {"position": [9.0] * 6}, msgtype=JS, log_time=t0)  # another arm: ignored


def test_load_commands_picks_commands_or_setpoints(tmp_path):
    _write_bag(tmp_path / "a")
    cmds = load_commands(tmp_path / "a")
    assert [c.topic for c in cmds] == ["state_command"] + ["servo_jp"] * 10
    assert cmds[0].t == 0.0 and cmds[1].t == pytest.approx(0.01) and cmds[-1].t == pytest.approx(0.1)
    assert cmds[0].joints is None and cmds[3].joints == ARM_JOINTS and list(cmds[3].position) == [0.02] * 6
    forced = load_commands(tmp_path / "a", from_setpoint=True, state_commands=False)
    assert [c.topic for c in forced] == ["servo_jp"] * 10 and forced[0].log_time % 10 == 1  # from setpoint_js
    _write_bag(tmp_path / "b", with_servo=False)
    auto = load_commands(tmp_path / "b")  # no position commands: the setpoints are used
    assert [c.topic for c in auto][1:] == ["servo_jp"] * 10
    assert len(load_commands(tmp_path / "a", ns="PSM2")) == 1
    enabled = prepend_enable(forced, 1.5)
    assert [T.decode(c.data, c.msgtype).string for c in enabled[:2]] == ["enable", "home"]
    assert enabled[2].t == pytest.approx(forced[0].t + 1.5)
    assert enabled[2].log_time - enabled[0].log_time == pytest.approx(enabled[2].t * 1e9)  # bag time aligned


class FakeClock:
    def __init__(self):
        self.now = 1000.0

    def __call__(self):
        return self.now

    def sleep(self, dt):
        self.now += max(dt, 1e-4)


def test_replay_keeps_timing_and_converges_with_a_loopback_twin():
    clock = FakeClock()
    twin = LoopbackTwin(clock=clock, tau=0.02)
    cmds = []
    for k in range(100):
        q = HOME + np.array([0.3, -0.2, 0.05, 0.5, 0.1, -0.1]) * min(1.0, k / 50)  # a ramp from home
        data = T.encode({"header": {"stamp": {"sec": 1}}, "position": q}, JS)[1]
        cmds.append(Command(k * 0.01, "servo_jp", JS, data, ARM_JOINTS, q, k))
    published = []

    def publish(topic, msgtype, data):
        published.append((clock(), topic, T.decode(data, msgtype)))
        twin.publish(topic, msgtype, data)

    result = replay(cmds, publish, twin, rate=2.0, settle=0.4, clock=clock, sleep=clock.sleep,
                    stamp_clock=lambda: 5_000_000_123)
    assert len(published) == 100
    sent_at = np.array([p[0] for p in published]) - 1000.0
    np.testing.assert_allclose(sent_at, [c.t / 2.0 for c in cmds], atol=2e-3)  # rate 2: twice as fast
    assert all(p[2].header.stamp.sec == 5 and p[2].header.stamp.nanosec == 123 for p in published)
    assert result.max_lateness < 2e-3
    err = tracking_error(result.reference(), result.measured)
    assert set(err) == set(ARM_JOINTS)
    for name in ARM_JOINTS:
        assert abs(err[name]["final"]) < 1e-6  # settled on the last command
        assert err[name]["max_abs"] < 0.05
    assert command_reference(c for _, c in result.commands).keys() == {ARM_JOINTS}


def test_restamp_only_touches_headers():
    data = T.encode({"header": {"stamp": {"sec": 1}, "frame_id": "f"}, "position": [1.0]}, JS)[1]
    back = T.decode(restamp(data, JS, 7_000_000_005), JS)
    assert (back.header.stamp.sec, back.header.stamp.nanosec, back.header.frame_id) == (7, 5, "f")
    empty = T.encode({}, "std_msgs/msg/Empty")[1]
    assert restamp(empty, "std_msgs/msg/Empty", 1) == empty


def test_cli_replays_the_sample_through_the_loopback_twin(tmp_path, capsys):
    from pathlib import Path

    sample = Path(__file__).resolve().parents[2] / "bags" / "psm1_sample"
    out = tmp_path / "response"
    assert record_cli(["replay", str(sample), "--loopback", "--rate", "4", "--out", str(out),
                       "--json", str(tmp_path / "err.json")]) == 0
    text = capsys.readouterr().out
    assert "tracking error" in text and "sim vs recorded" in text and "wrist_yaw" in text
    report = json.loads((tmp_path / "err.json").read_text())
    assert set(report["errors"]["tracking"]) == set(ARM_JOINTS + JAW_JOINTS)
    # the loopback model is the one that generated the sample (tau 30 ms): the sim-vs-recorded
    # gap is small compared with the motion
    assert all(e["rms"] < 0.05 for e in report["errors"]["sim_vs_recorded"].values())
    topics = {m.topic for m in read_messages(out)}
    assert {"/PSM1/servo_jp", "/PSM1/jaw/servo_jp", "/PSM1/state_command", "/PSM1/measured_js",
            "/PSM1/jaw/measured_js"} <= topics


def test_replay_over_ros_against_a_stand_in_twin(tmp_path, rclpy_env, ros_domain):
    """RclpyTwinLink <-> an rclpy node that echoes servo_jp into measured_js at 100 Hz."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import QoSProfile
    from sensor_msgs.msg import JointState

    from cressim.record.ros import RclpyTwinLink

    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    node = rclpy.create_node("stand_in_twin", context=ctx)
    state = {"q": [0.0] * 6}
    node.create_subscription(JointState, "/PSM1/servo_jp", lambda m: state.update(q=list(m.position)),
                             QoSProfile(depth=1))
    pub = node.create_publisher(JointState, "/PSM1/measured_js", QoSProfile(depth=100))

    def tick():
        msg = JointState(name=list(ARM_JOINTS), position=state["q"])
        msg.header.stamp = node.get_clock().now().to_msg()
        pub.publish(msg)
    node.create_timer(0.01, tick)
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(node)
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    out = tmp_path / "ros_response"
    recorder = BagWriter(out)
    link = None
    try:
        cmds = []
        for k in range(60):
            q = np.full(6, 0.002 * k)
            cmds.append(Command(k * 0.01, "servo_jp", JS, T.encode({"position": q}, JS)[1], ARM_JOINTS, q, k))
        link = RclpyTwinLink({"servo_jp": JS}, recorder=recorder)
        assert link.wait_for_twin(20.0) == []
        link.drain()
        result = replay(cmds, link.publish, link, settle=0.3)
    finally:
        if link is not None:
            link.close()
        recorder.close()
        executor.shutdown()
        node.destroy_node()
        ctx.shutdown()
    assert len(result.measured[ARM_JOINTS]) >= 50
    err = tracking_error(result.reference(), result.measured)
    assert abs(err["yaw"]["final"]) < 1e-9  # the echo reached the last command
    assert err["yaw"]["max_abs"] < 0.05
    counts = {}
    for m in read_messages(out):
        counts[m.topic] = counts.get(m.topic, 0) + 1
    assert counts["/PSM1/servo_jp"] == 60 and counts["/PSM1/measured_js"] >= 50
