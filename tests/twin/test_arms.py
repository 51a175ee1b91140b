"""cressim.twin.TwinArms without ROS: the dVRK's behaviour as events (homing that takes time,
`home` when homed, jaw clipping, limits at 80 degrees, a tool without jaw, trajectory ratios,
servo_cv) and the FK the services answer against the URDF model."""
import math
from types import SimpleNamespace

import numpy as np
import pytest
import torch
import yourdfpy

from cressim.robots import PSM
from cressim.robots.dvrk import PSM_JOINTS
from cressim.twin import JointCommand, StateReport


def _topics(events, topic):
    return [e.value for e in events if e.topic == topic]


def _home(arms, env=0):
    events = arms.state_command(env, "enable") + arms.state_command(env, "home")
    ticks = 0
    while arms.states[env].is_busy:
        events += arms.tick()
        ticks += 1
    return events, ticks


def test_homing_moves_to_home_and_takes_time(make_arms):
    arms = make_arms(cameras=False)
    events, ticks = _home(arms)
    states = _topics(events, "operating_state")
    assert states[1] == StateReport("ENABLED", False, True)  # busy while the joints move
    assert states[-1] == StateReport("ENABLED", True, False)
    assert ticks > 5, "homing from the initial to the home joints takes simulated time"
    assert np.allclose(arms.setpoint[0].numpy(), arms.scene.home_jp)
    # homed and idle: `home` answers at once, never busy, and a move right after is accepted
    again = arms.state_command(0, "home")
    assert _topics(again, "operating_state") == [StateReport("ENABLED", True, False)]
    assert not _topics(arms.move_jp(0, JointCommand(position=[0.1, 0, 0.12, 0, 0, 0])), "error")


def test_motion_refused_until_homed(make_arms):
    arms = make_arms(cameras=False)
    arms.state_command(0, "enable")
    arms.state_command(0, "home")
    refusal = _topics(arms.servo_jp(0, JointCommand(position=[0, 0, 0.1, 0, 0, 0])), "error")
    assert refusal and "homing is under way" in refusal[0]


def test_jaw_commands_are_clipped_and_80_degrees_is_a_limit(make_arms):
    arms = make_arms(cameras=False)
    _home(arms)
    assert arms.jaw_servo_jp(0, JointCommand(position=[2.0])) == []
    assert float(arms.jaw_sp[0, 0]) == pytest.approx(arms.jaw_upper)
    assert arms.jaw_servo_jp(0, JointCommand(position=[-3.0])) == []
    assert float(arms.jaw_sp[0, 0]) == pytest.approx(arms.jaw_lower)
    assert "is nan" in _topics(arms.jaw_servo_jp(0, JointCommand(position=[math.nan])), "error")[0].lower()
    # the URDF's wrist limit is 1.39626 (80 degrees rounded): exactly 80 degrees is accepted
    q = [0, 0, 0.12, 0, math.radians(80), -math.radians(80)]
    assert arms.servo_jp(0, JointCommand(position=q)) == []
    assert _topics(arms.servo_jp(0, JointCommand(position=[0, 0, 0.12, 0, 1.4, 0])), "error")


def test_suction_tool_refuses_jaw_and_wrist(make_arms):
    arms = make_arms(robot="psm_suction", cameras=False)
    _home(arms)
    assert "no jaw" in _topics(arms.jaw_move_jp(0, JointCommand(position=[0.3])), "error")[0]
    wrist = _topics(arms.servo_jp(0, JointCommand(position=[0.0, 0.0, 0.1, 0.0, 0.2, 0.0])), "error")[0]
    assert "wrist_pitch" in wrist and "no such joint" in wrist
    assert arms.servo_jp(0, JointCommand(position=[0.1, 0.0, 0.1, 0.5, 0.0, 0.0])) == []
    arms.tick()
    assert float(arms.setpoint[0, 3]) == 0.5


def test_trajectory_ratio_scales_moves(make_arms):
    arms = make_arms(cameras=False)
    _home(arms)
    goal = JointCommand(position=[0.5, 0, 0.12, 0, 0, 0])

    def duration():
        arms.move_jp(0, goal)
        ticks = 0
        while arms.states[0].is_busy:
            arms.tick()
            ticks += 1
        arms.move_jp(0, JointCommand(position=arms.scene.home_jp))
        while arms.states[0].is_busy:
            arms.tick()
        return ticks

    full = duration()
    events = arms.set_ratio(0, 0.25)
    assert _topics(events, "trajectory_j/ratio") == [0.25]
    quarter = duration()
    # yaw 0.5 rad at half the URDF's 2 rad/s and 4x that per s: a trapezoid of 1/V + V/A with
    # V = 1 / 0.5 and A = 4 / 0.5 per s, 0.75 s; both scaled by 0.25: 1/(rV) + V/A = 2.25 s
    assert full == pytest.approx(75, abs=2) and quarter == pytest.approx(225, abs=2)
    assert "(0, 1]" in _topics(arms.set_ratio(0, 1.5), "error")[0]


def test_servo_cv_moves_the_tip_along_the_twist(make_arms):
    arms = make_arms(cameras=False)
    _home(arms)
    tip0 = arms.kin.forward(arms.setpoint[:1])[0, :3, 3].clone()
    twist = SimpleNamespace(linear=SimpleNamespace(x=0.01, y=0.0, z=0.0), angular=SimpleNamespace(x=0, y=0, z=0))
    assert arms.servo_cv(0, twist) == []  # 10 mm/s, held until the next command
    for _ in range(5):
        arms.tick()
    moved = arms.kin.forward(arms.setpoint[:1])[0, :3, 3] - tip0
    assert moved[0] == pytest.approx(0.0005, rel=0.05) and abs(float(moved[1])) < 1e-5
    still = SimpleNamespace(linear=SimpleNamespace(x=0.0, y=0.0, z=0.0), angular=SimpleNamespace(x=0, y=0, z=0))
    assert arms.servo_cv(0, still) == []  # a zero twist stops it
    held = arms.setpoint.clone()
    arms.tick()
    assert torch.equal(held, arms.setpoint)


def test_forward_kinematics_equals_the_urdf_model(make_arms):
    """The FK the services answer, against the URDF chain (cressim.robots.PSM) for 1,000 random
    joint vectors: position within 1 um, rotation within 1e-6 (issue: the tip's rotation was
    applied twice)."""
    arms = make_arms(cameras=False)
    urdf = PSM(arms.psm.urdf_path, dtype=torch.float64)
    rng = np.random.default_rng(7)
    lower, upper = arms.kin.lower_np, arms.kin.upper_np
    q = rng.uniform(lower, upper, size=(1000, 6))
    expected = urdf.forward_kinematics(torch.as_tensor(q)).numpy()
    for k in range(1000):
        pose, problem = arms.forward(0, JointCommand(position=list(q[k])), local=True)
        assert problem is None
        x, y, z, w = pose[3:]
        R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                      [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                      [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
        assert np.abs(pose[:3] - expected[k, :3, 3]).max() < 1e-6
        assert np.abs(R - expected[k, :3, :3]).max() < 1e-6, k


def test_stale_check_uses_the_arrival_time_in_the_stamps_clock():
    from cressim.twin.command_checks import stale_refusal
    wall = 1_800_000_000 * 10**9
    assert stale_refusal(wall - 900_000_000, wall, 0, 1.0, what="servo_jp") is None  # 0.9 s old on arrival
    problem = stale_refusal(wall - 1_500_000_000, wall, 0, 1.0, what="servo_jp")
    assert problem.startswith("servo_jp refused: stale command, stamped 1.5 s before it arrived")
    # a client on /clock stamps in simulated time: compared with the twin's simulated time
    assert stale_refusal(5 * 10**9, wall, 5_500_000_000, 1.0, what="move_jp") is None
    assert "stamped 2 s" in stale_refusal(5 * 10**9, wall, 7 * 10**9, 1.0, what="move_jp")
    assert stale_refusal(0, wall, 0, 1.0, what="x") is None  # unstamped
    assert stale_refusal(1, wall, 0, 0.0, what="x") is None  # check off


def test_link_bodies_follow_the_urdf_forward_kinematics_on_the_gpu(make_arms):
    """Every env's link bodies, posed by the GPU's FK pass (cressim.robots.link_poses), sit where
    yourdfpy's FK of the URDF (float64, an implementation independent of ours) puts them for
    that env's joints: within 1e-5 m and 1e-5 in rotation (float32), mimic jaw blades included."""
    arms = make_arms(cameras=False, num_envs=3)
    bodies, engine = arms.bodies, arms.bodies.engine
    rng = np.random.default_rng(3)
    q = torch.as_tensor(rng.uniform(arms.kin.lower_np, arms.kin.upper_np, size=(3, 6)))
    jaw = torch.as_tensor(rng.uniform(0.0, 1.0, size=(3, 1)))
    bodies.write(q, jaw)
    engine.step_physics()
    engine.end_frame()
    urdf = yourdfpy.URDF.load(str(arms.psm.urdf_path), load_meshes=False)
    frames = {}  # link -> (3, 4, 4) in PSM1_base
    for env in range(3):
        urdf.update_cfg({**dict(zip(PSM_JOINTS, q[env].tolist())), "jaw": float(jaw[env, 0])})
        for link in bodies.body_names:
            frames.setdefault(link, []).append(urdf.get_transform(link, urdf.base_link))
    positions = engine.buffer("rigid.positions").read()
    rotations = engine.buffer("rigid.rotations").read()
    rows = bodies.body_rows.cpu().numpy()
    for k, link in enumerate(bodies.body_names):
        T = bodies.base.numpy() @ np.stack(frames[link])  # (3, 4, 4)
        for env in range(3):
            x, y, z, w = rotations[rows[env, k]].astype(np.float64)
            R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                          [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                          [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
            assert np.abs(positions[rows[env, k], :3] - T[env, :3, 3]).max() < 1e-5, (link, env)
            assert np.abs(R - T[env, :3, :3]).max() < 1e-5, (link, env)
