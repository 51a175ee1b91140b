"""Run-time edits of the particle system: strand frames held and driven by attachments, fluid
removal (host and task pass) with slot reuse, and cutting constraints. Small scenes for lavapipe;
tolerances in each test."""
import math
import textwrap

import numpy as np
import pytest

import cressim
from cressim.passes.suction import Suction

from .particle_scenes import lattice, open_box, positions, start, step, twist_angle


def _about_x(angle):
    return (math.sin(angle / 2), 0.0, 0.0, math.cos(angle / 2))


def _mul(a, b):
    """Hamilton product of xyzw quaternions."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    return np.concatenate([a[3] * b[:3] + b[3] * a[:3] + np.cross(a[:3], b[:3]), [a[3] * b[3] - a[:3] @ b[:3]]])


def _tool(world, env, name, x):
    tool = world.create_entity(env=env, name=name)
    tool.add(cressim.Transform(position=(x, 0, 1)))
    # no collider: it would push the held particle out
    tool.add(cressim.RigidBody(kinematic=True, mass=0.1, inertia=(1e-4, 1e-4, 1e-4)))
    return tool


# ---- driven strand frames ----------------------------------------------------------------

N, LENGTH, TURN = 11, 0.2, math.pi / 2


def _held_strands(make_engine):
    """Five envs, a straight cable along x (no gravity) in each, turned at its x = LENGTH end by
    TURN about x: env 0 held at both ends with frames, env 1 held (with frame) at the turning end
    only, env 2 held at both ends by position alone, env 3 like env 1 with a given frame offset:
    the end frame turned by a further TURN / 2, env 4 like env 0 with its middle bend-twist
    record cut."""
    world = cressim.World(cressim.SceneLayout(5))
    pts = np.stack([np.linspace(0, LENGTH, N), np.zeros(N), np.full(N, 1.0)], 1)
    tools = []
    for env in range(5):
        world.create_entity(env=env, name="cable").add(cressim.Strand(
            pts, mass=0.001, radius=0.005, twist_compliance=1e-3, bend_compliance=1e-3, damping=2.0))
        tools.append((_tool(world, env, "holder", 0.0), _tool(world, env, "turner", LENGTH)))
    engine = start(world, make_engine, particle_iterations=8, gravity=(0, 0, 0))
    off = engine.particle_mapping["env_offset"]
    end_frame = engine.buffer("particles.initial_orientations").read()[N - 2]
    for env, (holder, turner) in enumerate(tools):
        if env in (0, 2, 4):
            engine.attach_particle(env=env, slot=0, particle=int(off[env]), body=holder, hold_frame=env == 0)
        offset = tuple(_mul(_about_x(TURN / 2), end_frame)) if env == 3 else None
        engine.attach_particle(env=env, slot=1, particle=int(off[env]) + N - 1, body=turner, hold_frame=env != 2,
                               frame_offset=offset)
    chain = engine.particle_mapping["constraints"]["bend_twist"]["chains"][4]  # env 4's strand: (first row, count)
    engine.cut_constraints("bend_twist", [int(chain[0] + chain[1] // 2)])
    step(engine, 1)
    frames = 30
    for f in range(1, frames + 1):  # TURN over half a second, then rest
        for env in range(5):
            tools[env][1].transform = cressim.Transform(position=(LENGTH, 0, 1), rotation=_about_x(TURN * f / frames))
        step(engine, 1)
    step(engine, 60)
    return engine


def test_held_strand_frames_follow_the_turning_body(make_engine):
    engine = _held_strands(make_engine)
    q = engine.buffer("particles.orientations").read().reshape(5, N - 1, 4)
    q0 = engine.buffer("particles.initial_orientations").read().reshape(5, N - 1, 4)
    segment_twists = lambda e: np.array([twist_angle(q[e, i], q[e, i + 1]) for i in range(N - 2)])  # noqa: E731
    # held at both ends: a uniform rod at rest twists evenly, TURN / 9 in each of the 9 segment
    # pairs (the equilibrium of equal torsional compliances in series), within 0.1 deg
    both = segment_twists(0)
    assert np.abs(both - TURN / (N - 2)).max() < math.radians(0.1), np.degrees(both)
    # the middle record cut: each half follows its own held end untwisted, the cut pair takes the turn
    cut = segment_twists(4)
    middle = (N - 2) // 2
    assert abs(cut[middle] - TURN) < math.radians(0.1), np.degrees(cut)
    assert np.abs(np.delete(cut, middle)).max() < math.radians(0.1), np.degrees(cut)
    # held at the turning end only: the relaxed cable turns with the body, every frame within 0.1 deg
    one = np.array([twist_angle(q0[1, i], q[1, i]) for i in range(N - 1)])
    assert np.abs(one - TURN).max() < math.radians(0.1)
    # held by position only, the turn does not reach the cable's frames
    assert abs(segment_twists(2).sum()) < math.radians(1)
    # a given offset is kept instead of the one at attach time: 1.5 TURN in all
    given = np.array([twist_angle(q0[3, i], q[3, i]) for i in range(N - 1)])
    assert np.abs(given - 1.5 * TURN).max() < math.radians(0.1)
    # the centrelines stay straight along x
    p = positions(engine)
    assert np.abs(p[:, 1]).max() < 1e-3 and np.abs(p[:, 2] - 1).max() < 1e-3


def test_hold_frame_errors_name_the_particle(make_engine):
    world = cressim.World(cressim.SceneLayout(1))
    world.create_entity(env=0, name="blob").add(cressim.SoftBody(cressim.TetMesh.box((0.05, 0.05, 0.05), (1, 1, 1))))
    tool = _tool(world, 0, "tool", 0.0)
    engine = start(world, make_engine)
    with pytest.raises(ValueError, match="hold_frame needs a strand particle; particle 3"):
        engine.attach_particle(env=0, slot=0, particle=3, body=tool, hold_frame=True)
    with pytest.raises(ValueError, match="frame_offset needs hold_frame=True"):
        engine.attach_particle(env=0, slot=0, particle=3, body=tool, frame_offset=(0, 0, 0, 1))


# ---- fluid removal -----------------------------------------------------------------------

BUDGET, RATE = 80, 4


def _fluid(make_engine):
    """Two identical envs: a 4 x 4 x 4 block of fluid (r 2 cm) in a box, an emitter above it
    filling the rest of the budget (16 slots) at 4 a frame."""
    world = cressim.World(cressim.SceneLayout(2))
    block = lattice((4, 4, 4), 0.04, (-0.06, -0.06, 0.02))
    for env in range(2):
        open_box(world, env, (0.1, 0.1), height=0.6)
        w = world.create_entity(env=env, name="blood")
        w.add(cressim.Transform())
        w.add(cressim.Fluid(block, budget=BUDGET, radius=0.02, emit_rate=RATE, emit_width=2,
                            emit_origin=(0, 0, 0.4), emit_velocity=(0, 0, -1)))
    return start(world, make_engine, substeps=2, particle_iterations=3)


def _active(engine):
    return (engine.buffer("particles.phases").read()[:, 3] & 1).astype(bool)


def test_removed_fluid_slots_are_freed_and_reused(make_engine):
    engine, reference = _fluid(make_engine), _fluid(make_engine)
    step(engine, 12)
    step(reference, 12)
    assert _active(engine).sum() == 2 * BUDGET  # full
    p, before = positions(engine), _active(engine)
    centre = p[:BUDGET][before[:BUDGET]].mean(0)
    inside = np.nonzero(before & (np.arange(2 * BUDGET) < BUDGET) & (np.linalg.norm(p - centre, axis=1) < 0.05))[0]
    assert len(inside) > RATE  # more than one frame of emission
    engine.remove_particles(inside)
    step(engine, 1)
    step(reference, 1)
    active, emitted = _active(engine), engine.buffer("particles.emitted").read()
    # exactly those slots freed; the emitter took the lowest RATE of them again at once
    assert active[:BUDGET].sum() == BUDGET - len(inside) + RATE == emitted[0]
    assert np.all(active[inside[:RATE]]) and not np.any(active[inside[RATE:]])
    kept = np.setdiff1d(np.arange(BUDGET), inside)
    assert np.all(active[kept])
    # the emitter refills the rest of them over the next frames, and no more
    frames = math.ceil((len(inside) - RATE) / RATE)
    step(engine, frames)
    step(reference, frames)
    assert _active(engine).sum() == 2 * BUDGET and list(engine.buffer("particles.emitted").read()) == [BUDGET] * 2
    # env 1 never saw any of it: bit for bit the run without removal
    assert np.array_equal(positions(engine)[BUDGET:], positions(reference)[BUDGET:])
    with pytest.raises(ValueError, match=r"particle 3 .*is not a fluid particle"):
        _soft_engine(make_engine).remove_particles([3])


def _soft_engine(make_engine):
    world = cressim.World(cressim.SceneLayout(1))
    world.create_entity(env=0, name="blob").add(cressim.SoftBody(cressim.TetMesh.box((0.05, 0.05, 0.05), (1, 1, 1))))
    return start(world, make_engine)




def test_a_task_pass_removes_fluid_inside_a_sphere(make_engine):
    world = cressim.World(cressim.SceneLayout(2))
    for env in range(2):
        open_box(world, env, (0.1, 0.1), height=0.6)
        w = world.create_entity(env=env, name="blood")
        w.add(cressim.Transform())
        w.add(cressim.Fluid(lattice((4, 4, 4), 0.04, (-0.06, -0.06, 0.02)), radius=0.02))
    engine = start(world, make_engine, substeps=2, particle_iterations=3)
    n = 128
    tip = (0.0, 0.0, 0.06)
    suction = Suction(engine, None, tip, 0.05)
    suction.set([True, False])  # env 0 only
    step(engine, 5)
    engine.step_physics()
    suction.execute()
    engine.end_frame()
    p = positions(engine)
    inside = (np.arange(n) < 64) & (np.linalg.norm(p - np.array(tip), axis=1) < 0.05)
    assert 0 < inside.sum() < 64
    step(engine, 1)  # applied at the next step's start
    active = _active(engine)
    assert np.array_equal(active, ~inside)  # exactly those, in env 0 only
    assert list(engine.buffer("particles.emitted").read()) == [64 - inside.sum(), 64]
    assert not engine.buffer("control.particle_remove").read().any()  # flags consumed
    assert list(suction.removed()) == [inside.sum(), 0]
    engine.reset_envs([0])
    step(engine, 1)
    assert _active(engine).all()


def test_suction_draws_fluid_in_as_a_point_sink(make_engine):
    """No gravity, lone fluid particles 50 mm from a suction tip in six directions and one 150 mm
    out (beyond the 120 mm reach): while on, the near ones come in as a point sink of flow rate Q
    at a wall draws them, dr/dt = -Q / (2 pi r^2), so r^3 = r0^3 - 3 Q t / (2 pi); they are removed
    inside the 10 mm radius; the far one stays, and so does everything in env 1 (suction off)."""
    tip, r0, q = np.array([0.0, 0.0, 1.0]), 0.05, 2e-4
    directions = np.concatenate([np.eye(3), -np.eye(3)])
    points = np.concatenate([tip + r0 * directions, [tip + [0.15, 0, 0]]]).astype(np.float32)
    world = cressim.World(cressim.SceneLayout(2))
    for env in range(2):
        world.create_entity(env=env, name="blood").add(cressim.Fluid(points, radius=0.002))
    engine = start(world, make_engine, substeps=4, gravity=(0, 0, 0))
    suction = Suction(engine, None, tip, 0.01, flow_rate=q, reach=0.12)
    suction.set([True, False])
    dt, frames = engine.physics.dt, 30
    for _ in range(frames):
        suction.execute()
        engine.step_physics()
        engine.end_frame()
    p = positions(engine).reshape(2, -1, 3)
    r = np.linalg.norm(p[0, :6] - tip, axis=1)
    expected = (r0 ** 3 - 3 * q * frames * dt / (2 * math.pi)) ** (1 / 3)  # 36.8 mm
    np.testing.assert_allclose(r, expected, rtol=0.02)
    np.testing.assert_allclose(p[0, 6], points[6], atol=1e-6)  # out of reach
    np.testing.assert_allclose(p[1], points, atol=1e-6)  # env 1's suction is off
    inside = (r0 ** 3 - 0.01 ** 3) * 2 * math.pi / (3 * q)  # s until they reach the mouth (at the latest)
    for _ in range(int(inside / dt) + 5):
        suction.execute()
        engine.step_physics()
        engine.end_frame()
    assert list(suction.removed()) == [6, 0]
    assert list(_active(engine)) == [False] * 6 + [True] * 8


def test_suction_flow_rates_are_checked(make_engine):
    world = cressim.World(cressim.SceneLayout(2))
    for env in range(2):
        world.create_entity(env=env, name="blood").add(cressim.Fluid(lattice((2, 2, 2), 0.01), radius=0.005))
    engine = start(world, make_engine)
    suction = Suction(engine, None, (0, 0, 0), 0.01)
    with pytest.raises(ValueError, match="flow_rate of env 1 must be finite and >= 0, got nan"):
        suction.set_flow([1e-5, float("nan")])
    with pytest.raises(ValueError, match="reach must be at least the radius 0.01"):
        Suction(engine, None, (0, 0, 0), 0.01, reach=0.005)


# ---- cutting -----------------------------------------------------------------------------

CUT_X = 0.025  # between the beam's vertex layers at x = 0 and 0.05


def _beam(make_engine):
    """Two envs, a soft cantilever (0.3 x 0.1 x 0.1 m, clamped at x = -0.15) in each."""
    world = cressim.World(cressim.SceneLayout(2))
    mesh = cressim.TetMesh.box((0.15, 0.05, 0.05), (6, 2, 2))
    for env in range(2):
        beam = world.create_entity(env=env, name="beam")
        beam.add(cressim.Transform(position=(0, 0, 1)))
        beam.add(cressim.SoftBody(mesh, fixed=np.nonzero(mesh.positions[:, 0] < -0.1499)[0], mass=0.05,
                                  distance_compliance=1e-3, volume_compliance=1e-3, damping=5.0))
    return start(world, make_engine, substeps=4, particle_iterations=8), len(mesh.positions)


def _crossing(engine, family, count, env):
    """Rows of particles.<family>_constraints of env `env` with particles on both sides of x = CUT_X."""
    rec = engine.buffer(f"particles.{family}_constraints").read()[:, :count].astype(np.int64)
    x = engine.buffer("particles.initial_positions").read()[:, 0]
    side = x[rec] > CUT_X
    env_of = engine.buffer("particles.phases").read()[rec[:, 0], 2]
    return np.nonzero(side.any(1) & ~side.all(1) & (env_of == env))[0]


def _gap(p, rest_x):
    """Distance between the centres of the two cut faces (rest x = 0 and x = 0.05)."""
    return np.linalg.norm(p[np.abs(rest_x - 0.05) < 1e-4].mean(0) - p[np.abs(rest_x) < 1e-4].mean(0))


def test_cutting_a_beam_across_a_plane_splits_it(make_engine):
    (engine, n), (reference, _) = _beam(make_engine), _beam(make_engine)
    step(engine, 20)
    step(reference, 20)
    distance, volume = _crossing(engine, "distance", 2, 0), _crossing(engine, "volume", 4, 0)
    assert len(distance) > 0 and len(volume) > 0
    engine.cut_constraints("distance", distance)
    engine.cut_constraints("volume", volume)
    rest_x = engine.buffer("particles.initial_positions").read()[:n, 0]
    right = rest_x > CUT_X
    gaps = [_gap(positions(engine)[:n], rest_x)]
    cut_centre = positions(engine)[:n][right].mean(0)
    for _ in range(3):
        step(engine, 10)
        step(reference, 10)
        gaps.append(_gap(positions(engine)[:n], rest_x))
    # the free piece falls away: the gap between the cut faces grows every 1/6 s (from one cell,
    # 5 cm), and its centre drops as a body falling with the damping (5 / s) would, within 5 %
    # (z(t) = g / c (t - (1 - exp(-c t)) / c), from rest: the sag's own motion is left out)
    assert np.all(np.diff(gaps) > 0.05)
    t, c = 0.5, 5.0
    fall = 9.81 / c * (t - (1 - math.exp(-c * t)) / c)
    assert cut_centre[2] - positions(engine)[:n][right, 2].mean() == pytest.approx(fall, rel=0.05)
    # each piece keeps its shape: every remaining edge within 2 % of its rest length
    rec = engine.buffer("particles.distance_constraints").read()[:, :2].astype(np.int64)
    rest = engine.buffer("particles.distance_constraints").read().view(np.float32)[:, 4]
    p = positions(engine)
    whole = np.setdiff1d(np.nonzero(rec[:, 0] < n)[0], distance)
    strain = np.linalg.norm(p[rec[whole, 0]] - p[rec[whole, 1]], axis=1) / rest[whole] - 1
    assert np.abs(strain).max() < 0.02
    # the clamped piece still hangs from its clamp, and env 1 is bit for bit the uncut run
    assert p[:n][~right, 2].min() > 0.9
    assert np.array_equal(p[n:], positions(reference)[n:])
    # an env reset makes the beam whole again
    engine.reset_envs([0])
    step(engine, 1)
    assert not engine.buffer("control.particle_distance_cut").read().any()
    assert not engine.buffer("control.particle_volume_cut").read().any()


def test_cut_errors_name_the_family_and_row(make_engine):
    engine, _ = _beam(make_engine)
    with pytest.raises(ValueError, match="no constraint family 'tendon'.*distance, volume"):
        engine.cut_constraints("tendon", [0])
    with pytest.raises(IndexError, match="row 99999 of particles.distance_constraints is out of range"):
        engine.cut_constraints("distance", [0, 99999])
    assert not engine.buffer("control.particle_distance_cut").read().any()  # nothing written


# a task pass cutting every constraint of a family whose first particle is in env `env`
CUT_ALL = textwrap.dedent("""
    struct Params { uint count; uint env; };
    [[vk::push_constant]] ConstantBuffer<Params> pc;
    StructuredBuffer<uint4> constraints;  // ParticleConstraint rows: uint4 particles, float4 params
    StructuredBuffer<uint4> phases;
    RWStructuredBuffer<uint> cut;

    [numthreads(64, 1, 1)]
    void main(uint3 id : SV_DispatchThreadID) {
      if (id.x < pc.count && phases[constraints[2 * id.x].x].z == pc.env) cut[id.x] = 1;
    }
""")


def test_a_task_pass_cuts_constraints(make_engine):
    engine, n = _beam(make_engine)
    for family in ("distance", "volume"):
        count = len(engine.buffer(f"particles.{family}_constraints").read())
        engine.execute_compute_pass(engine.create_compute_pass(
            CUT_ALL, name=f"cut_{family}", threads=count,
            bindings={"constraints": f"particles.{family}_constraints", "phases": "particles.phases",
                      "cut": f"control.particle_{family}_cut"},
            constants={"count": count, "env": 0}))
    step(engine, 15)
    # env 0 is loose particles: every free one fell as a damped point mass for 1/4 s (21 cm),
    # within 2 %; env 1's beam still hangs, within its few cm of sag
    free = engine.buffer("particles.positions").read()[:n, 3] > 0  # not clamped
    drop = engine.buffer("particles.initial_positions").read()[:, 2] - positions(engine)[:, 2]
    t, c = 0.25, 5.0
    fall = 9.81 / c * (t - (1 - math.exp(-c * t)) / c)
    assert np.abs(drop[:n][free] / fall - 1).max() < 0.02
    assert drop[n:].max() < 0.05
