"""The twin's pure-Python parts without DDS: scene parsing, trajectories, checks, state machine."""
import math
from pathlib import Path

import numpy as np
import pytest
import torch

from cressim.twin.arm_state import ArmState
from cressim.twin.command_checks import joint_values, pose_matrix
from cressim.twin_scene_file import SceneError, load_scene, parse_scene
from cressim.twin.trajectory import BatchedTrajectory

REPO = Path(__file__).resolve().parents[2]
NAMES = ("yaw", "pitch", "insertion", "roll", "wrist_pitch", "wrist_yaw")
LOWER = np.array([-1.588, -0.925025, 0.0, -4.53786, -1.39626, -1.39626])
UPPER = -LOWER
UPPER[2] = 0.24


def test_default_scene_parses():
    scene = load_scene(str(REPO / "scenes" / "psm_twin.yaml"))
    assert (scene.arm, scene.robot, scene.num_envs) == ("PSM1", "psm_lnd", 1)
    assert scene.publish_rate == 100.0 and scene.physics_rate == 200.0 and scene.particle_rate == 0.0  # the same
    assert parse_scene("rates:\n  physics: 800\n  particles: 200\n").particle_rate == 200.0
    assert parse_scene("").num_envs == 1  # an empty file: defaults


@pytest.mark.parametrize("text, where, words", [
    ("arm:\n  base:\n    position: [1, 2]\n", "x.yaml:3:15", "expected 3 numbers"),
    ("num_env: 3\n", "x.yaml:1:1", "unknown field"),
    ("rates:\n  publish: 100\n  physics: 150\n", "x.yaml:3:12", "integer multiple"),
    ("rates:\n  physics: 800\n  particles: 250\n", "x.yaml:3:14", "integer multiple"),
    ("rates:\n  physics: 200\n  particles: 400\n", "x.yaml:3:14", "above the physics rate"),
    ("arm:\n  robot: psm_foo\n", "x.yaml:2:10", "not one of"),
    ("num_envs: two\n", "x.yaml:1:11", "expected an integer"),
    ("arm:\n  base:\n    rotation: [0, 0, 0, 2]\n", "x.yaml:3:15", "norm"),
    ("arm: [\n", "x.yaml:2:1", "not valid YAML"),
    ("sensors: [joints, radar]\n", "x.yaml:1:19", "radar"),
])
def test_scene_errors_name_line_and_field(text, where, words):
    with pytest.raises(SceneError) as info:
        parse_scene(text, "x.yaml")
    assert str(info.value).startswith(where + ":"), str(info.value)
    assert words in str(info.value)


def test_trajectory_limits_and_synchronisation():
    traj = BatchedTrajectory(3, 2)
    v, a = np.array([1.0, 0.5]), np.array([2.0, 2.0])
    d0 = traj.start(0, [0.0, 0.0], [1.0, 0.1], v, a, now=0.0)  # joint 0 limits: trapezoid
    d1 = traj.start(2, [0.0, 0.0], [0.0, 0.05], v, a, now=0.0)  # short: triangle
    assert d0 == pytest.approx(1.0 / 1.0 + 1.0 / 2.0)  # 1/V + V/A with V = 1, A = 2
    assert d1 == pytest.approx(2 * math.sqrt(0.05 / 2.0))
    dt, prev, prev_v = 1e-3, None, None
    for k in range(1, 2000):
        q, qd, moving, finished = traj.evaluate(k * dt)
        if prev is not None:
            vel = (q - prev) / dt
            assert (vel.abs()[0] <= torch.tensor(v) + 1e-6).all()
            if prev_v is not None and moving[0]:
                assert ((vel[0] - prev_v[0]).abs() / dt <= torch.tensor(a) + 1e-3).all()
            prev_v = vel
        # straight line: joints stay proportional (they arrive together)
        if moving[0]:
            assert float(q[0, 1]) == pytest.approx(0.1 * float(q[0, 0]), abs=1e-12)
        prev = q
        if finished[0]:
            assert k * dt >= d0 - dt and float(q[0, 0]) == 1.0
    assert not traj.active.any()
    assert not moving[1]  # env 1 never started


def test_joint_values_checks():
    JointState = pytest.importorskip("sensor_msgs.msg").JointState  # a ROS message package

    ok = JointState(position=[0.0, 0.0, 0.1, 0.0, 0.0, 0.0])
    q, problem = joint_values(ok, what="servo_jp", names=NAMES, lower=LOWER, upper=UPPER)
    assert problem is None and q[2] == 0.1
    for msg, words in [
        (JointState(position=[0.0] * 5), "5 position values, expected 6"),
        (JointState(position=[0.0, math.nan, 0.1, 0, 0, 0]), "position[1] (pitch) is nan"),
        (JointState(position=[0.0, 0.0, 0.3, 0, 0, 0]), "insertion = 0.3 is beyond its limits [0, 0.24]"),
        (JointState(name=["a"] * 6, position=[0.0] * 6), "unknown joint name 'a'"),
        (JointState(name=list(NAMES[:5]) + ["yaw"], position=[0.0] * 6), "given twice"),
    ]:
        q, problem = joint_values(msg, what="servo_jp", names=NAMES, lower=LOWER, upper=UPPER)
        assert q is None and words in problem, problem


def test_pose_checks():
    Pose = pytest.importorskip("geometry_msgs.msg").Pose

    pose = Pose()
    pose.orientation.w = 1.0
    T, problem = pose_matrix(pose, what="servo_cp")
    assert problem is None and np.allclose(T, np.eye(4))
    pose.orientation.w = 0.0
    assert "norm 0" in pose_matrix(pose, what="servo_cp")[1]
    pose.orientation.w, pose.position.y = 1.0, math.inf
    assert "position.y is not finite" in pose_matrix(pose, what="servo_cp")[1]


def test_operating_state_machine():
    s = ArmState()
    assert s.motion_refusal("servo_jp").startswith("servo_jp refused: the arm is DISABLED")
    t = s.command("enable")
    assert t.publish and s.state == "ENABLED"
    assert "not homed" in s.motion_refusal("move_jp")
    t = s.command("home")
    assert t.start_homing and s.is_busy and "homing" in s.motion_refusal("move_jp")
    s.homing_done()
    assert s.is_homed and not s.is_busy and s.motion_refusal("move_jp") is None
    assert s.command("pause").stop_motion and s.state == "PAUSED"
    assert s.command("home").error  # paused: resume first
    assert s.command("resume").publish and s.state == "ENABLED"
    assert "unknown state command" in s.command("jump").error
    s.command("disable")
    assert s.state == "DISABLED" and s.is_homed  # disable keeps the homing
    t = s.command("home")  # from DISABLED: powers up first, as the dVRK does
    assert t.start_homing and s.state == "ENABLED"


def test_dynamics_option():
    from cressim_ros import params as P

    assert load_scene(str(REPO / "scenes" / "psm_twin.yaml")).dynamics == "kinematic"
    assert parse_scene("arm:\n  dynamics: dynamic\n").dynamics == "dynamic"
    with pytest.raises(SceneError) as info:
        parse_scene("arm:\n  dynamics: soft\n", "x.yaml")
    assert str(info.value).startswith("x.yaml:2:13:") and "not one of kinematic, dynamic" in str(info.value)
    cfg = P.defaults(parse_scene(""))
    assert "not one of" in P.check({"dynamics": "soft"}, cfg, running=False)
    assert P.check({"dynamics": "dynamic"}, cfg, running=False) is None
    assert "restart" in P.check({"dynamics": "dynamic"}, cfg, running=True)
