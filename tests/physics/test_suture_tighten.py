"""A stitch pulled tight (docs/particles.md, "Suturing"): the demo's two 10 kPa flaps 4 mm apart,
one bite across the gap with 40 mm of thread, the needle drawn out along its arc and then away
until the knot catches at the entry and the thread's tension reaches a target. The taut thread
runs straight from puncture to puncture, keeps its length, and draws the flaps together, the
more the harder it is pulled; the hand holding the needle bears the pull; an env reset lets the
knot go. With friction on the thread, a stitch pulled on loses tension at each puncture by the
capstan law (Euler-Eytelwein)."""
import numpy as np
import pytest

import cressim
from cressim.demos import suture as demo
from cressim.suture import PUNCTURED, needle_mesh, punctures, thread_tension

BITE = (0.0,)
THREAD = (0.04, 21)  # m, particles: 2 mm segments, as the demo's


def _sew(friction=0.0, squeeze=0.0, table=True, gravity=None):
    """The bite made and the needle drawn out along its arc: (engine, world, frame, dt, centre,
    theta, gap before, the hand's body row)."""
    world = cressim.World(cressim.SceneLayout(1))
    meshes = {"table": world.add_mesh(cressim.Mesh.plane(0.1)),
              "needle": world.add_mesh(needle_mesh(demo.RADIUS, demo.ANGLE, 0.00035))}
    needle = demo.author_env(world, 0, meshes, 8, 8, camera=False, bites=BITE, thread=THREAD, friction=friction,
                             squeeze=squeeze, table=table)
    hand = world.create_entity(env=0, name="hand")  # holds the needle: bears its load
    hand.add(cressim.Transform(position=(0.0, 0.0, 0.05)))
    hand.add(cressim.RigidBody(kinematic=True, mass=0.01, inertia=(1e-6, 1e-6, 1e-6)))
    engine = cressim.Engine(world)
    if gravity is not None:
        physics = engine.physics
        physics.gravity = gravity
        engine.physics = physics
    engine.prepare()
    engine.upload_world()
    row = [int(e) for e in engine.buffer("rigid.body_entity").read()].index(hand.id)  # its body row
    engine.buffer("control.needle_holders").write(np.array([row + 1], np.uint32))
    dt = engine.physics.dt

    def frame(centre, theta):
        needle.transform = cressim.Transform(position=tuple(centre), rotation=demo._quat(theta))
        engine.step_physics()
        engine.end_frame()

    steps = demo.motion(dt, bites=BITE)
    for _, centre, theta in steps:
        frame(centre, theta)
    before = demo.gaps(engine, world, BITE)[0]
    theta, _ = demo.needle_out(engine, frame, steps[-1][1], steps[-1][2], dt)
    return engine, world, frame, dt, steps[-1][1], theta, before, row


@pytest.fixture(scope="module")
def sewn():
    return _sew()


def _thread(engine, world):
    m = engine.particle_mapping
    o, c = [(int(o), int(c)) for e, o, c in zip(m["object_entity"], m["object_offset"], m["object_count"])
            if world.entity(int(e)).name == "thread"][0]
    return engine.buffer("particles.positions").read()[o:o + c]


def test_a_stitch_pulled_tight_closes_the_wound_the_harder_the_more(sewn):
    engine, world, frame, dt, centre, theta, before, hand = sewn
    weight = 0.001 * np.asarray(engine.physics.gravity)  # the needle's (RigidBody mass 1 g)
    assert abs(before - demo.GAP) < 0.2e-3
    records = punctures(engine)[0]
    assert len(records) == 4 and all(r["state"] == PUNCTURED and r["s"] > demo.RADIUS * demo.ANGLE for r in records)
    closed = []
    for target in (0.02, 0.05):
        # slowly (5 mm/s): the short thread goes taut within a frame, and the tension overshoots by
        # what the needle moved in it
        centre, frames, tension = demo.pull_tight(engine, frame, centre, theta, dt, target, limit=round(16 / dt),
                                                  speed=0.005)
        assert abs(tension - target) < 0.1 * target, (target, tension, frames)
        records = sorted(punctures(engine)[0], key=lambda r: r["s"])
        # the knot caught at the entry (the first puncture made: the last along the thread), and
        # only there
        assert [r["knot"] for r in records] == [False, False, False, True]
        # without friction on the thread the tension is the same either side of each puncture
        assert all(abs(r["friction"]) < 0.02 * target for r in records[:-1]), [r["friction"] for r in records]
        # taut: from puncture to puncture the thread runs straight (within a segment's length)
        assert all(abs(v) < 2.5e-3 for v in demo.slack(records)), demo.slack(records)
        x = _thread(engine, world)
        length = np.linalg.norm(np.diff(x[:, :3], axis=0), axis=1).sum()
        assert abs(length - THREAD[0]) < 0.01 * THREAD[0], length
        closed.append(demo.gaps(engine, world, BITE)[0])
        # the hand holding the needle bears its weight and the thread's pull at the tail: the
        # tension along the thread's way to its first puncture
        string = engine.buffer("particles.needle_threads").read()[0]
        assert string[0] == pytest.approx(target, rel=0.15)
        first = records[0]["point"]
        tail = _thread(engine, world)[0, :3]
        way = (first - tail) / np.linalg.norm(first - tail)
        assert np.dot(string[1:], way) > 0.99, (string, way)
        load = engine.buffer("rigid.contact_forces").read()[hand, :3]
        np.testing.assert_allclose(load, weight + string[0] * string[1:], atol=0.02 * target)
    assert before - closed[0] > 0.3e-3, (before, closed)  # the tension draws the flaps together
    assert closed[0] - closed[1] > 0.05e-3, closed  # and more of it, further
    assert engine.health_events == 0
    # the knot is an anchor of the thread while it holds: an env reset lets it go and gives the
    # thread's last particle its mass back
    assert _thread(engine, world)[-1, 3] == 0
    engine.reset_envs([0])
    frame(centre, theta)
    assert punctures(engine)[0] == [] and thread_tension(engine)[0] == 0
    assert _thread(engine, world)[-1, 3] > 0


def _tensions(engine, world):
    """Along a caught stitch, from the needle's tail to the knot: each span's tension (N; the
    first the needle's, each next one less the friction at the puncture between) and the string's
    turn at each puncture between two spans (rad)."""
    records = sorted(punctures(engine)[0], key=lambda r: r["s"])
    T = [float(thread_tension(engine)[0])]
    for r in records[:-1]:
        T.append(T[-1] - r["friction"])
    x = [_thread(engine, world)[0, :3]] + [r["point"] for r in records]
    turns = []
    for j in range(1, len(x) - 1):
        a, b = x[j] - x[j - 1], x[j + 1] - x[j]
        turns.append(float(np.arccos(np.clip(np.dot(a, b) / np.linalg.norm(a) / np.linalg.norm(b), -1, 1))))
    return np.array(T), np.array(turns)


def test_a_stitch_pulled_on_with_friction_loses_tension_by_the_capstan_law():
    """mu 0.3 with capstan friction alone (a squeeze of 1 uN): pulled on slowly once taut, the
    thread slides through every puncture, and the tension before each over that after it is
    exp(mu theta), theta the stitch's turn there (Euler-Eytelwein), so the knot's side bears less
    than the needle pulls with."""
    mu = 0.3
    engine, world, frame, dt, centre, theta, _, _ = _sew(friction=mu, squeeze=1e-6)
    centre, _, tension = demo.pull_tight(engine, frame, centre, theta, dt, 0.02, limit=round(16 / dt), speed=0.005)
    assert abs(tension - 0.02) < 0.002
    way = np.asarray(demo.PULL) / np.linalg.norm(demo.PULL)
    for _ in range(round(2.0 / dt)):  # 4 mm at 2 mm/s: every puncture slips
        centre = centre + way * 0.002 * dt
        frame(centre, theta)
    T, turns = _tensions(engine, world)
    assert [r["knot"] for r in sorted(punctures(engine)[0], key=lambda r: r["s"])] == [False, False, False, True]
    assert np.all(turns > 0.1), turns  # the stitch turns at each: the law has something to show
    np.testing.assert_allclose(T[:-1] / T[1:], np.exp(mu * turns), rtol=0.03)
    assert T[-1] < 0.7 * T[0], T
    assert engine.health_events == 0


def test_the_flaps_close_under_the_stitch_as_linear_elasticity_says():
    """The closing against the flaps' own stiffness, checked against scikit-fem: the bite made
    with no table and no gravity (each flap held only at its far edge), the stitch pulled to
    0.02 N and held still until the tissue has settled; then each flap's displacement from rest
    where the stitch holds it matches static linear elasticity (P1 tets on the same mesh, the
    same E and nu, the far edge clamped) under the pulls the punctures report, spread on their
    triangles' corners by their weights as the engine spreads them."""
    from .fem_reference import static_displacement

    engine, world, frame, dt, centre, theta, _, _ = _sew(table=False, gravity=(0.0, 0.0, 0.0))
    centre, _, tension = demo.pull_tight(engine, frame, centre, theta, dt, 0.02, limit=round(16 / dt), speed=0.005)
    for _ in range(round(1.0 / dt)):  # held still: the tissue settles under the stitch
        frame(centre, theta)
    records = punctures(engine)[0]
    assert len(records) == 4 and records and all(r["state"] == PUNCTURED for r in records)
    assert thread_tension(engine)[0] > 0.01  # still taut
    x = engine.buffer("particles.positions").read()[:, :3]
    surface = engine.buffer("particles.surface").read()
    mesh = cressim.TetMesh.box(demo.FLAP, demo.CELLS)
    rest = np.asarray(mesh.positions, dtype=np.float64)
    m = engine.particle_mapping
    compared = 0
    for e, o, c in zip(m["object_entity"], m["object_offset"], m["object_count"]):
        name = world.entity(int(e)).name
        if name not in ("left_flap", "right_flap"):
            continue
        side = -1 if name == "left_flap" else 1
        o, c = int(o), int(c)
        loads = np.zeros((c, 3))
        held = []
        for r in records:
            corners = surface[r["triangle"]]
            if not (o <= corners[0] < o + c):
                continue
            loads[corners - o] += np.outer(r["weights"], -r["force"])  # the stitch's pull on the tissue
            held.append(r)
        assert len(held) == 2, name  # each flap holds two punctures of the bite
        ref = static_displacement(rest, np.asarray(mesh.tets), lambda p: side * p[0] > demo.FLAP[0] - 1e-6,
                                  10e3, 0.45, 1050, gravity=(0.0, 0.0, 0.0), point_loads=loads)
        origin = np.array([side * (demo.GAP / 2 + demo.FLAP[0]), 0, demo.FLAP[2] + demo.PARTICLE])
        moved = x[o:o + c] - (rest + origin)
        for r in held:
            corners = surface[r["triangle"]] - o
            engine_u, fem_u = r["weights"] @ moved[corners], r["weights"] @ ref[corners]
            assert np.linalg.norm(fem_u) > 0.2e-3, fem_u  # the stitch moves the tissue measurably
            np.testing.assert_allclose(engine_u, fem_u, atol=0.1 * np.linalg.norm(fem_u)), (name, engine_u, fem_u)
            compared += 1
    assert compared == 4
    assert engine.health_events == 0


def test_friction_holds_a_stitch_once_the_needle_lets_up():
    """mu 0.3 with a squeeze of 5 mN: pulled on until the needle's side bears 0.05 N, then the
    needle brought 20 mm back so that its side goes slack. The stitch slips toward it until each
    puncture holds its far side at the most friction can: T_next = T exp(mu theta) + mu N from the
    needle's slack side on (the capstan law with the squeeze). So tension stays inside the stitch
    and the wound stays partly closed, where without friction it would open again."""
    mu, squeeze = 0.3, 0.005
    engine, world, frame, dt, centre, theta, before, _ = _sew(friction=mu, squeeze=squeeze)
    way = np.asarray(demo.PULL) / np.linalg.norm(demo.PULL)
    # pulled on at 5 mm/s until the needle's side bears 0.05 N (a tension held there by a controller
    # stick-slips through the punctures' friction)
    for _ in range(round(16 / dt)):
        if thread_tension(engine)[0] >= 0.05:
            break
        centre = centre + way * 0.005 * dt
        frame(centre, theta)
    assert thread_tension(engine)[0] >= 0.05
    for _ in range(round(2.0 / dt)):  # 20 mm back
        centre = centre - way * 0.01 * dt
        frame(centre, theta)
    for _ in range(round(1.0 / dt)):
        frame(centre, theta)
    T, turns = _tensions(engine, world)
    assert T[0] < 1e-3, T  # the needle's side slack
    np.testing.assert_allclose(T[1:], T[:-1] * np.exp(mu * turns) + mu * squeeze, rtol=0.05)
    assert demo.gaps(engine, world, BITE)[0] < before - 0.3e-3
    assert engine.health_events == 0
