"""Batched headless mode: num_envs = 2 twins in one engine under /env0/PSM1 and /env1/PSM1.

Env 1 is enabled, homed and moved; env 0 must not notice (its own state machine, its own
rows of the batched state). /PSM1 (without prefix) exists only when num_envs = 1. /clock runs
and every stamp is non-zero.
"""
import time

import numpy as np
import pytest
from rosgraph_msgs.msg import Clock

from twin_fixtures import keeps_publishing, module_twin

pytestmark = pytest.mark.ros


@pytest.fixture(scope="module")
def batched(request, tmp_path_factory, twin_domain):
    from cressim_ros.dvrk_client import Arm, Ral

    twin = module_twin(request, tmp_path_factory, twin_domain, "num_envs:=2")
    ral = Ral("batched_client", twin_domain)
    arms = [Arm(ral, f"/env{i}/PSM1") for i in range(2)]
    ral.check_connections(timeout=30)
    for arm in arms:
        assert arm._measured_js.wait_for(lambda m: True, 5)
        assert arm._state.wait_for(lambda m: True, 5)
    yield twin, ral, arms
    ral.shutdown()
    assert twin.alive(), twin.output()


def test_namespaces(batched):
    twin, ral, arms = batched
    topics = dict(ral.node.get_topic_names_and_types())
    for i in range(2):
        for name in ("measured_js", "setpoint_js", "measured_cp", "jaw/measured_js", "operating_state", "error",
                     "servo_jp", "move_cp", "state_command", "body/jacobian"):
            assert f"/env{i}/PSM1/{name}" in topics, name
    assert not [t for t in topics if t.startswith("/PSM1/")], "unprefixed topics in batched mode"
    services = dict(ral.node.get_service_names_and_types())
    assert "/env1/PSM1/operating_state" in services and "/env0/PSM1/inverse_kinematics" in services


def test_envs_are_independent(batched):
    twin, ral, (arm0, arm1) = batched
    q0 = arm0.measured_jp()
    assert arm1.enable(5) and arm1.home(10)
    goal = np.array([-0.3, 0.2, 0.15, -0.5, 0.1, 0.3])
    assert arm1.move_jp(goal).wait(10)
    assert arm1.wait_measured(10, timeout=60)  # the 5 ms measured lag, in ticks
    np.testing.assert_allclose(arm1.measured_jp(), goal, atol=1e-6)
    np.testing.assert_allclose(arm0.measured_jp(), q0, atol=1e-12)
    assert arm0.operating_state().state == "DISABLED" and not arm0.operating_state().is_homed
    # env 0 refuses (it is disabled), env 1 got no error
    errors1 = arm1.errors.count
    before = arm0.errors.count
    arm0.servo_jp(goal)
    assert arm0.errors.wait_for(lambda m: arm0.errors.count > before and m.data.startswith("env0/PSM1:"), 3)
    assert arm1.errors.count == errors1
    # both envs keep publishing
    assert keeps_publishing(arm0) and keeps_publishing(arm1)


def test_clock_and_tf(batched):
    twin, ral, arms = batched
    from cressim_ros.dvrk_client import _Latest
    from cressim_ros.topics import LATCHED_QOS
    from tf2_msgs.msg import TFMessage

    clock, tf, static = _Latest(keep=50), _Latest(keep=50), _Latest()
    ral.subscriber(Clock, "/clock", clock, 1)
    ral.subscriber(TFMessage, "/tf", tf, 100)
    ral.subscriber(TFMessage, "/tf_static", static, LATCHED_QOS)
    assert clock.wait_for(lambda m: clock.count >= 20, 5)
    times = [m.clock.sec + m.clock.nanosec * 1e-9 for m in clock.history]
    assert times[0] > 0 and all(b > a for a, b in zip(times, times[1:]))
    assert tf.wait_for(lambda m: tf.count >= 10, 5)
    for m in tf.history:  # one message per tick: every env's base -> tip, then its URDF links
        pairs = [(t.header.frame_id, t.child_frame_id) for t in m.transforms]
        assert pairs[:2] == [("env0/PSM1_base", "env0/PSM1"), ("env1/PSM1_base", "env1/PSM1")]
        for env in range(2):  # as robot_state_publisher: each link from its parent link
            assert (f"env{env}/PSM1_base", f"env{env}/PSM1_mount_link") in pairs
            assert (f"env{env}/PSM1_wrist_yaw_link", f"env{env}/PSM1_jaw_link") in pairs
        assert len(pairs) == len(set(pairs)) and all(t.header.stamp.sec > 0 for t in m.transforms)
    # latched: a late subscriber still gets world -> base and world -> camera of each env
    assert static.wait_for(lambda m: True, 5)
    pairs = {(t.header.frame_id, t.child_frame_id) for t in static.msg.transforms}
    assert pairs == {(f"env{i}/world", f"env{i}/{child}") for i in range(2)
                     for child in ("PSM1_base", "camera_color_optical_frame")}, pairs


def test_cameras_per_env(batched):
    twin, ral, arms = batched
    from cressim_ros.dvrk_client import _Latest
    from sensor_msgs.msg import Image

    images = [_Latest() for _ in range(2)]
    for i, latest in enumerate(images):
        ral.subscriber(Image, f"/env{i}/camera/color/image_raw", latest, 2)
    for i, latest in enumerate(images):
        assert latest.wait_for(lambda m: True, 10), f"no image on /env{i}/camera/color/image_raw"
        m = latest.msg
        assert m.header.frame_id == f"env{i}/camera_color_optical_frame"
        assert (m.width, m.height, m.encoding, m.step) == (64, 48, "rgb8", 64 * 3)
