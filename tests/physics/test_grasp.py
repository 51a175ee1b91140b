"""Grasping tissue with a tool (cressim.passes.Grasp): a closed grasp holds the particles within
reach to the tool body, the tool lifts them by as much as it moves, opening lets go, the tool
reads the weight of what it carries, and a dynamic tool bears it."""
import numpy as np
import pytest

import cressim
from cressim.passes.grasp import Grasp

from .particle_scenes import positions, start, static, step

G = 9.81
FLAP = (0.03, 0.02, 0.003)  # half extents (m): a 60 x 40 x 6 mm flap
RADIUS = 0.002


TOOL_MASS = 0.2  # kg
SLIDER_STIFFNESS = 100.0  # N/m: the dynamic tool's vertical position drive


def _tool(world, env, position, dynamic=False):
    tool = world.create_entity(env=env, name="jaws")
    tool.add(cressim.Transform(position=position))
    tool.add(cressim.RigidBody(kinematic=not dynamic, mass=TOOL_MASS, inertia=(1e-4, 1e-4, 1e-4)))  # no collider
    if dynamic:  # on a vertical slider, critically damped
        world.create_entity(env=env, name="slider").add(cressim.Joint(
            "slider", body_b=tool, anchor=position, axis=(0, 0, 1), drive="position", target=0.0, stiffness=SLIDER_STIFFNESS,
            damping=2 * (SLIDER_STIFFNESS * TOOL_MASS) ** 0.5))
    return tool


def _flap_scene(make_engine, clamped=True, envs=2, dynamic=False, **settings):
    """A 10 kPa flap on a table, its x = -30 mm edge fixed to it (or free), and a tool over its
    x = +30 mm edge in every env (kinematic, or dynamic on a driven vertical slider)."""
    world = cressim.World(cressim.SceneLayout(envs))
    mesh = cressim.TetMesh.box(FLAP, (10, 6, 2))
    rest = np.asarray(mesh.positions)
    fixed = np.nonzero(rest[:, 0] < -FLAP[0] + 1e-6)[0] if clamped else []
    tools = []
    for env in range(envs):
        static(world, env, [cressim.Shape.plane()], "table")
        flap = world.create_entity(env=env, name="flap")
        flap.add(cressim.Transform(position=(0, 0, FLAP[2] + RADIUS)))
        flap.add(cressim.SoftBody(mesh, fixed=fixed, youngs_modulus=1e4, poisson_ratio=0.45, density=1000.0,
                                  radius=RADIUS, damping=5.0))
        tools.append(_tool(world, env, (FLAP[0], 0, 2 * FLAP[2] + RADIUS), dynamic))
    engine = start(world, make_engine, **{"max_particle_attachments_per_env": 8, **settings})
    return engine, tools, rest


def test_a_grasp_lifts_the_flap_by_the_tool_motion_and_lets_go(make_engine):
    engine, tools, rest = _flap_scene(make_engine)
    grasp = Grasp(engine, tools, point=(0, 0, -FLAP[2]), radius=0.005)
    step(engine, 60)  # settle on the table
    settled = positions(engine).reshape(2, -1, 3)
    grasp.set([True, False])  # env 1's jaws stay open
    grasp.execute()
    step(engine, 1)
    held = grasp.held()
    assert held[0] > 0 and held[1] == 0
    lift = 0.02
    for f in range(1, 31):  # 20 mm up over half a second, then hold for a second
        tools[0].transform = cressim.Transform(position=(FLAP[0], 0, 2 * FLAP[2] + RADIUS + lift * f / 30))
        step(engine, 1)
    step(engine, 60)
    x = positions(engine).reshape(2, -1, 3)
    attached = engine.buffer("control.particle_attachments").read()[:held[0], 0].astype(np.int64)
    rise = x[0, attached, 2] - settled[0, attached, 2]
    np.testing.assert_allclose(rise, lift, atol=0.5e-3)  # held where the tool took them, moved with it
    edge = rest[:, 0] > FLAP[0] - 1e-6
    assert x[0, edge, 2].mean() - settled[0, edge, 2].mean() > 0.6 * lift  # the flap's edge comes up (its corners sag)
    assert abs(x[1] - settled[1]).max() < 1e-4  # the open tool in env 1 leaves its flap alone
    grasp.set([False, False])
    grasp.execute()
    step(engine, 90)
    assert grasp.held()[0] == 0
    np.testing.assert_allclose(positions(engine).reshape(2, -1, 3)[0, edge, 2], settled[0, edge, 2], atol=1e-3)


def test_the_tool_reads_the_weight_it_carries(make_engine):
    """A free flap lifted off the table hangs from the tool: its contact force is m g."""
    engine, tools, rest = _flap_scene(make_engine, clamped=False, envs=1)
    grasp = Grasp(engine, tools, point=(0, 0, -FLAP[2]), radius=0.006)
    step(engine, 30)
    grasp.set([True])
    grasp.execute()
    for f in range(1, 61):
        tools[0].transform = cressim.Transform(position=(FLAP[0], 0, 2 * FLAP[2] + RADIUS + 0.08 * f / 60))
        step(engine, 1)
    step(engine, 240)  # the hanging flap settles (damping 5/s)
    assert positions(engine)[:, 2].min() > 0.01  # off the table
    forces = step_mean_force(engine, 30)
    weight = 1000.0 * 8 * FLAP[0] * FLAP[1] * FLAP[2] * G
    np.testing.assert_allclose(forces, [0, 0, -weight], atol=0.05 * weight)


@pytest.mark.parametrize("settings", [{}, {"substeps": 8, "particle_substeps": 2}], ids=["same", "particles_slower"])
def test_a_dynamic_tool_bears_the_flap_it_lifts(make_engine, settings):
    """A dynamic tool on a vertical slider drive (stiffness k) lifts a free flap off the table: at
    rest the drive holds the tool and the flap, so it sags by (M + m) g / k (here 21 mm, of which
    the flap is 1.4 mm); env 1's open tool carries nothing and sags by M g / k. Also with the
    bodies substepping 4x as often as the particles (the twin's dynamic arm over tissue)."""
    engine, tools, rest = _flap_scene(make_engine, clamped=False, envs=2, dynamic=True,
                                      **settings)
    grasp = Grasp(engine, tools, point=(0, 0, -FLAP[2]), radius=0.006)
    targets = engine.buffer("control.joint_targets")
    sag = TOOL_MASS * G / SLIDER_STIFFNESS
    t = targets.read()
    t[:, 0] = sag  # the tool's drive starts where it holds the tool at its authored height
    targets.write(t)
    step(engine, 30)
    grasp.set([True, False])
    grasp.execute()
    for f in range(1, 61):
        t[:, 0] = sag + 0.08 * f / 60
        targets.write(t)
        step(engine, 1)
    step(engine, 240)  # the hanging flap settles (damping 5/s)
    x = positions(engine).reshape(2, -1, 3)
    assert x[0, :, 2].min() > 0.01  # off the table
    q = np.mean([step(engine, 1) or engine.buffer("joint.positions").read().copy() for _ in range(60)], axis=0)
    weight = 1000.0 * 8 * FLAP[0] * FLAP[1] * FLAP[2] * G
    carried = (t[:, 0] - q) * SLIDER_STIFFNESS - TOOL_MASS * G  # what the drive holds beyond the tool
    np.testing.assert_allclose(carried, [weight, 0], atol=0.05 * weight)


def step_mean_force(engine, frames):
    out = []
    for _ in range(frames):
        step(engine, 1)
        out.append(engine.buffer("rigid.contact_forces").read()[0, :3].copy())
    return np.mean(out, axis=0)


def test_grasp_arguments_are_checked(make_engine):
    engine, tools, _ = _flap_scene(make_engine, envs=1)
    with pytest.raises(ValueError, match="radius must be positive"):
        Grasp(engine, tools, point=(0, 0, 0), radius=-1)
    with pytest.raises(ValueError, match="1 bodies for 2 envs|2 bodies for 1 envs"):
        Grasp(engine, tools * 2, point=(0, 0, 0), radius=0.01)
