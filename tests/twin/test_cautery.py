"""The twin over heat (scenes/psm_cautery.yaml: a slab of liver), without ROS: the needle
driver's jaws, resting on the liver, are energized by the coagulation pedal (the footpedals/coag command) and
coagulate the tissue at their middle; released, they heat nothing; env 1's pedal stays up; the
suction tool and a world without heat refuse the pedal."""
import numpy as np

from cressim.twin_scene_file import load_scene

from arm_moves import jaws_at, run_ticks, settle

TOP = np.array([0.0, 0.0, 0.1615])  # the liver's top at its centre


def _jaw_point(arms, env):
    """The jaws' middle (the cautery's tip) in the world, from the engine's body pose."""
    engine = arms.bodies.engine
    row = int(arms.instrument("cautery").cautery.commands.read()[env, 1])
    p, q = engine.buffer("rigid.positions").read()[row, :3], engine.buffer("rigid.rotations").read()[row]
    tip = arms.instrument("cautery").cautery.tips.read()[env, :3]
    x, y, z, w = q
    u = np.array([x, y, z])
    t = 2 * np.cross(u, tip)
    return p + tip + w * t + np.cross(u, t)


def test_the_coag_pedal_coagulates_the_liver_at_the_jaws(make_arms):
    arms = make_arms(scene=load_scene("psm_cautery.yaml"), num_envs=2)
    assert arms.instrument("cautery") is not None
    for env in range(2):
        arms.state_command(env, "enable")
        arms.state_command(env, "home")
    settle(arms)
    jaws_at(arms, 0.0, jaws=[0.0, 0.0], point=TOP)  # the jaws' middle at the liver's top, pressing it
    engine = arms.bodies.engine
    assert np.linalg.norm(_jaw_point(arms, 0) - TOP) < 0.001
    assert not arms.instrument_command(0, "footpedals/coag", True)
    run_ticks(arms, 100)  # a second at 30 W
    t = engine.buffer("particles.temperatures").read().reshape(2, -1)
    damage = engine.buffer("particles.damage").read().reshape(2, -1)
    x = engine.buffer("particles.positions").read()[:, :3].reshape(2, -1, 3)
    near = np.linalg.norm(x[0] - _jaw_point(arms, 0), axis=1) < arms.scene.cautery_radius
    assert (damage[0, near] > 1.0).sum() >= 2 and t[0].max() > 333.15, (t[0].max(), damage[0, near])
    assert np.abs(t[1] - 310.15).max() < 1e-3 and damage[1].max() == 0  # env 1's pedal is up
    coagulated = (damage[0] > 1.0).sum()
    assert not arms.instrument_command(0, "footpedals/coag", False)
    run_ticks(arms, 50)
    damage = engine.buffer("particles.damage").read().reshape(2, -1)
    assert (damage[0] > 1.0).sum() <= coagulated + 4  # released: the cooling edge adds little
    t_after = engine.buffer("particles.temperatures").read().reshape(2, -1)
    assert t_after[0].max() < t[0].max()  # no more heat in: it spreads and the peak falls
    assert not engine.buffer("control.particle_tet_cut").read().any()  # coag mode cuts nothing


def test_the_pedal_is_refused_where_nothing_can_burn(make_arms):
    arms = make_arms(scene=load_scene("psm_retraction.yaml"))  # its flap has no heat
    refused = arms.instrument_command(0, "footpedals/coag", True)
    assert "footpedals/coag refused: the world has no tissue that takes heat" in refused[0].value
    assert not arms.instrument_command(0, "footpedals/coag", False)  # releasing is never an error
    arms = make_arms(scene=load_scene("psm_suction.yaml"))
    assert "has no jaws to energize" in arms.instrument_command(0, "footpedals/coag", True)[0].value
    assert arms.states[0].state == "DISABLED" and arms.instrument("cautery") is None
