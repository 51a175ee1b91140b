"""The twin sewing (scenes/psm_suture.yaml), without ROS: a needle held in the needle driver's jaws
punctures the pad when the arm pushes its tip in, in env 0 only, and an env reset lets go; opened,
the jaws let the needle go, and closed over it again they pick it up. The ROS side needs nothing
of its own: the arm and its jaws are driven by the dVRK's topics as always."""
import numpy as np
import pytest
import torch

from cressim.robots.arm_bodies import NEEDLE_WIRE
from cressim.twin import JointCommand

from cressim.suture import punctures
from cressim.twin_scene_file import load_scene

from arm_moves import jaws_at, run_ticks, settle

TOP = np.array([0.0, 0.0, 0.1615])  # the pad's top at its centre
TABLE_BESIDE = np.array([0.06, 0.0, 0.15])  # the table's top beside the pad
G = 9.81


def _tip(arms, env):
    """The needle's tip in the world (the detect pass's last tip)."""
    return arms.bodies.engine.buffer("particles.needle_states").read()[env, :3]


def _homed(make_arms):
    """Two envs of the sewing twin, enabled and at home."""
    arms = make_arms(scene=load_scene("psm_suture.yaml"), num_envs=2)
    for env in range(2):
        arms.state_command(env, "enable")
        arms.state_command(env, "home")
    settle(arms)
    return arms


def test_the_needle_in_the_jaws_punctures_the_pad_where_the_arm_pushes_it(make_arms):
    arms = _homed(make_arms)
    assert punctures(arms.bodies.engine) == [[], []]
    above = _tip(arms, 0)[2] - TOP[2]
    assert above > 0.005  # home: the needle clear of the pad
    # with the jaws down (home) the needle's arc is level, across them: env 0's jaws go 4 mm into
    # the pad, env 1's stop 10 mm above it
    jaws_at(arms, np.array([-0.004, 0.010]), point=TOP)
    first, second = punctures(arms.bodies.engine)
    assert _tip(arms, 0)[2] < TOP[2] - 0.003 and _tip(arms, 1)[2] > TOP[2] + 0.005
    assert len(first) == 1 and first[0]["state"] == 2  # the tip went through the top
    assert abs(first[0]["contact"][2] - TOP[2]) < 0.001  # where it met the surface
    assert second == []
    # the tool feels the pad holding the needle back (up, against the push) in env 0, and in env 1
    # the needle's weight alone
    weight = G * arms.bodies.needle_mass[0]
    assert float(arms.instrument("contact").wrench[0, 2]) > 10 * weight, arms.instrument("contact").wrench[0]
    torch.testing.assert_close(arms.instrument("contact").wrench[1, :3], torch.tensor([0, 0, -weight], dtype=torch.float64),
                               atol=1e-3 * weight, rtol=0)
    arms.bodies.engine.reset_envs([0])  # the pad as authored: the puncture is gone
    run_ticks(arms, 1)
    assert all(r["state"] != 2 for r in punctures(arms.bodies.engine)[0])


def _moved(arms, envs, rise):
    """Commands `envs`' tools `rise` m back along the shaft (insertion) and waits."""
    for env in envs:
        q = arms.setpoint[env].clone()
        q[2] -= rise
        assert not [e for e in arms.move_jp(env, JointCommand(position=q.tolist())) if e.topic == "error"]
    settle(arms)


def _jaws(arms, env, angle):
    arms.jaw_move_jp(env, JointCommand(position=[angle]))
    settle(arms)


def test_the_jaws_let_the_needle_go_and_pick_it_up_again(make_arms):
    arms = _homed(make_arms)
    # both envs' jaws beside the pad, their middle (the needle's arc) 1.5 mm over the table
    jaws_at(arms, np.array([0.0015, 0.0015]), point=TABLE_BESIDE)
    tip = lambda: (arms.bodies.base @ arms.kin.forward(arms.measured))[:, :3, 3].clone()  # noqa: E731
    start, tips = arms.bodies.needle_poses(), tip()
    assert arms.instrument("needle").held.tolist() == [True, True]
    _jaws(arms, 0, 0.8)  # env 0 opens: the needle drops onto the table and lies there
    assert arms.instrument("needle").held.tolist() == [False, True]
    _moved(arms, [0, 1], 0.01)
    now, moved = arms.bodies.needle_poses(), tip() - tips
    assert float(moved[:, 2].min()) > 0.009  # both tools rose 10 mm
    assert abs(float(now[0, 2, 3]) - (TABLE_BESIDE[2] + NEEDLE_WIRE)) < 1e-4  # left behind, on the table
    torch.testing.assert_close(now[0, :2, 3], start[0, :2, 3], atol=1e-3, rtol=0)
    torch.testing.assert_close(now[1, :3, 3] - start[1, :3, 3], moved[1], atol=1e-5, rtol=0)  # carried
    torch.testing.assert_close(now[1, :3, :3], start[1, :3, :3], atol=1e-5, rtol=0)
    _jaws(arms, 0, -0.2)  # closed 10 mm above it: nothing to take
    assert not arms.instrument("needle").held[0]
    _jaws(arms, 0, 0.8)
    _moved(arms, [0], -0.01)  # back down around it, and closed: picked up where the jaws hold it
    _jaws(arms, 0, -0.2)
    assert arms.instrument("needle").held.tolist() == [True, True]
    base, at = arms.bodies.needle_poses()[0], tip()[0]
    _moved(arms, [0], 0.01)  # and carried again
    torch.testing.assert_close(arms.bodies.needle_poses()[0, :3, 3] - base[:3, 3], tip()[0] - at, atol=1e-5, rtol=0)
    arms.reset_envs([0])  # a reset: the needle back in the jaws as authored
    run_ticks(arms, 2)
    assert arms.instrument("needle").held[0]


def _on_arc(arms, env, s):
    """The point of env's needle s m from its tip along the arc (world)."""
    A, R = arms.scene.needle["arc_angle"], arms.scene.needle["arc_radius"]
    T = arms.bodies.needle_poses()[env].numpy()
    phi = A - s / R
    return T[:3, :3] @ np.array([R * np.cos(phi), R * np.sin(phi), 0.0]) + T[:3, 3]


# A needle let go of with its tip through the pad is chaotic in this solver: the same scene with the
# arm's base moved by 1e-9 m (or the URDF chain's poses, 1e-8 m from the DH frames') leaves it
# jumping between punctures, 1 to 11 cm from where it was let go within the second, and the env
# flagged for speed now and then (measured on lavapipe for tip depths of 3 to 7 mm, 2026-12-08).
# It passed before only by those bits. Deterministic here, so strict: a solver that holds a
# threaded needle (issue 39, physics that holds under load) turns this into a pass to keep.
@pytest.mark.xfail(strict=True, reason="a needle hung from its punctures is not stable yet (issue 39)")
def test_a_needle_let_go_of_in_the_pad_hangs_from_its_puncture(make_arms):
    """Env 0's jaws push the needle's tip through the pad's top and let go: the needle, now free,
    hangs from the punctures (the pad's surface points stay on its arc, within 0.5 mm; a puncture
    is a point, so it swings about them) rather than fall through: over a second it stays threaded,
    its centre within its diameter of where it was let go; env 1's jaws hold theirs."""
    arms = _homed(make_arms)
    jaws_at(arms, np.array([-0.004, 0.010]), point=TOP)
    let_go, R = arms.bodies.needle_poses()[0], arms.scene.needle["arc_radius"]
    _jaws(arms, 0, 0.8)
    for _ in range(10):
        run_ticks(arms, 10)
        assert arms.bodies.health_flags().tolist() == [0, 0]
        # it turns about a point of its own: its centre stays within its diameter of where it was
        assert float((arms.bodies.needle_poses()[0, :3, 3] - let_go[:3, 3]).norm()) < 2 * R + 0.002
        assert any(r["state"] == 2 for r in punctures(arms.bodies.engine)[0])
    assert arms.instrument("needle").held.tolist() == [False, True]
    through = [r for r in punctures(arms.bodies.engine)[0] if r["state"] == 2]
    assert through
    for r in through:
        assert np.linalg.norm(r["point"] - _on_arc(arms, 0, r["s"])) < 5e-4


def _body(arms, key, env):
    return torch.from_dlpack(arms.bodies.engine.buffer(key))[arms.bodies.needle_rows[env], :3].cpu().double()


def test_a_needle_let_go_of_falls_and_comes_to_rest_on_the_table(make_arms):
    """Put 30 mm over the table beside the pad, at rest and out of the jaws, env 0's needle falls
    freely (g t^2 / 2, and semi-implicit Euler's g t h / 2 with h the substep; speed g t) and lies
    flat on the table (its wire's radius over the top); env 1's stays in its jaws, untouched."""
    arms = _homed(make_arms)
    held = arms.bodies.needle_poses()[1].clone()
    pose = np.eye(4)  # the arc level
    pose[:3, 3] = TABLE_BESIDE + np.array([0.0, 0.0, 0.03])
    arms.instrument("needle").set_pose(arms, 0, pose)
    z0 = float(_body(arms, "rigid.positions", 0)[2])
    ticks = 6  # 60 ms, the fall takes 78
    run_ticks(arms, ticks)
    t, h = ticks * arms.bodies.dt, arms.bodies.dt / arms.bodies.engine.physics.substeps
    drop = z0 - float(_body(arms, "rigid.positions", 0)[2])
    assert drop == pytest.approx(G * t * t / 2 + G * t * h / 2, rel=0.01)
    assert float(_body(arms, "rigid.linear_velocities", 0)[2]) == pytest.approx(-G * t, rel=0.01)
    run_ticks(arms, 100)
    lying = arms.bodies.needle_poses()[0]
    assert abs(float(lying[2, 3]) - (TABLE_BESIDE[2] + NEEDLE_WIRE)) < 1e-4  # the arc's centre, flat
    assert float(lying[2, 2]) > 0.999  # its plane level
    assert float(_body(arms, "rigid.linear_velocities", 0).norm()) < 1e-3  # at rest
    torch.testing.assert_close(arms.bodies.needle_poses()[1], held, atol=1e-6, rtol=0)
    assert arms.instrument("needle").held.tolist() == [False, True]


def test_a_dynamic_arm_bears_the_needle_it_holds(make_arms):
    """The dynamic arm (jointed bodies): the jaws' body bears the needle's weight, which the tool
    reports (its force m g down, its torque about the tool tip that of m g at the needle's centre of
    mass); pushed 4 mm into the pad, the tool feels the pad hold the needle back and the insertion
    drive bears that load along the shaft (J^T w): its proportional and integral terms over those of
    env 1, whose tool holds its needle 10 mm above the pad."""
    scene = load_scene("psm_suture.yaml")
    scene.dynamics = "dynamic"
    arms = make_arms(scene=scene, num_envs=2)
    for env in range(2):
        arms.state_command(env, "enable")
        arms.state_command(env, "home")
    settle(arms)
    run_ticks(arms, 10)
    weight = torch.tensor([0.0, 0.0, -G * arms.bodies.needle_mass[0]], dtype=torch.float64)
    tip = (arms.bodies.base @ arms.kin.forward(arms.measured))[:, :3, 3]
    for env in range(2):
        force, torque = arms.instrument("contact").wrench[env, :3], arms.instrument("contact").wrench[env, 3:]
        torch.testing.assert_close(force, weight, atol=0.02 * float(weight.norm()), rtol=0)
        arm = _body(arms, "rigid.positions", env) - tip[env]
        torch.testing.assert_close(torque, torch.linalg.cross(arm, weight),
                                   atol=0.02 * float(arm.norm() * weight.norm()), rtol=0)
    jaws_at(arms, np.array([-0.004, 0.010]), point=TOP)
    run_ticks(arms, 50)
    assert any(r["state"] == 2 for r in punctures(arms.bodies.engine)[0])
    snap, load = arms.snapshot(), []
    for env in range(2):
        J, _ = arms.kin.jacobian(arms.measured[env:env + 1])
        load.append(-(J[0].T @ torch.as_tensor(snap.spatial_cf[env]))[2].item())  # N, in along the shaft
    b = arms.bodies
    drive = b.stiffness[2] * (b._bias[:, 2] + arms.setpoint[:, 2] - arms.measured[:, 2])
    assert load[0] > 0.5 and abs(float(drive[0] - drive[1]) - (load[0] - load[1])) < 0.1 * load[0], (load, drive)


@pytest.mark.ros
def test_a_client_drives_the_needle_into_the_pad_over_dds(make_node):
    import torch
    from sensor_msgs.msg import JointState

    from arm_moves import JAW_MIDDLE
    from hand_ticked import client_beside, homed

    node = make_node(scene="psm_suture.yaml", sensors=["joints", "clock"])
    arms = homed(node)
    # where the jaws' middle is 4 mm into the pad: the client commands it by CRTK move_jp
    T = arms.kin.forward(arms.setpoint[0:1])[0].clone()
    T[:3, 3] = torch.as_tensor(TOP + np.array([0, 0, -0.004 + JAW_MIDDLE])) - arms.bodies.base[:3, 3]
    q, ok = arms.kin.inverse(T[None], arms.setpoint[0:1])
    assert bool(ok[0])
    engine = arms.bodies.engine
    with client_beside(node, "sewing_client") as (client, until):
        move = client.create_publisher(JointState, "/PSM1/move_jp", 10)
        until(lambda: move.get_subscription_count() > 0, "the twin does not listen on /PSM1/move_jp")
        move.publish(JointState(position=q[0].tolist()))
        until(lambda: any(r["state"] == 2 for r in punctures(engine)[0]), "the needle did not go into the pad",
              ticks=600)
    assert _tip(arms, 0)[2] < TOP[2]
