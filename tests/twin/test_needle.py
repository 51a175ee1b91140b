"""The twin sewing (scenes/psm_suture.yaml), without ROS: a needle held in the needle driver's jaws
punctures the pad when the arm pushes its tip in, in env 0 only, and an env reset lets go; opened,
the jaws let the needle go, and closed over it again they pick it up. The ROS side needs nothing
of its own: the arm and its jaws are driven by the dVRK's topics as always."""
import numpy as np
import pytest
import torch

from cressim.twin import JointCommand

from cressim.suture import punctures
from cressim.twin.scene import load_scene

from arm_moves import jaws_at, run_ticks, settle

TOP = np.array([0.0, 0.0, 0.1615])  # the pad's top at its centre


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
    tip = lambda: (arms.bodies.base @ arms.kin.forward(arms.measured))[:, :3, 3].clone()  # noqa: E731
    start, tips = arms.bodies.needle_poses(), tip()
    assert arms.needle_held.tolist() == [True, True]
    _jaws(arms, 0, 0.8)  # env 0 opens: the needle stays where it was let go
    assert arms.needle_held.tolist() == [False, True]
    _moved(arms, [0, 1], 0.01)
    now, moved = arms.bodies.needle_poses(), tip() - tips
    assert float(moved[:, 2].min()) > 0.009  # both tools rose 10 mm
    torch.testing.assert_close(now[0], start[0], atol=1e-6, rtol=0)  # left behind
    torch.testing.assert_close(now[1, :3, 3] - start[1, :3, 3], moved[1], atol=1e-5, rtol=0)  # carried
    torch.testing.assert_close(now[1, :3, :3], start[1, :3, :3], atol=1e-5, rtol=0)
    _jaws(arms, 0, -0.2)  # closed 10 mm above it: nothing to take
    assert not arms.needle_held[0]
    _jaws(arms, 0, 0.8)
    _moved(arms, [0], -0.01)  # back down around it, and closed: picked up where the jaws hold it
    _jaws(arms, 0, -0.2)
    assert arms.needle_held.tolist() == [True, True]
    base, at = arms.bodies.needle_poses()[0], tip()[0]
    _moved(arms, [0], 0.01)  # and carried again
    torch.testing.assert_close(arms.bodies.needle_poses()[0, :3, 3] - base[:3, 3], tip()[0] - at, atol=1e-5, rtol=0)
    arms.reset_envs([0])  # a reset: the needle back in the jaws as authored
    run_ticks(arms, 2)
    assert arms.needle_held[0]


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
