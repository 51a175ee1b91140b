"""Suturing (cressim.Needle, particle_needle_*.comp.hlsl) at the default settings on lavapipe: a 16 mm
3/8-circle needle on a kinematic body, turned about its centre so that its tip runs along its own
arc, bites through a block of 10 kPa tissue; its thread (2-0 braid, a Strand of a material) is
drawn through the punctures; the thread's end is a knot that catches at the first puncture."""
import math

import numpy as np
import pytest

import cressim
from cressim.suture import INDENTING, PUNCTURED, punctures

from .particle_scenes import positions, start

R, A, H = 0.008, 3 * math.pi / 4, 0.003  # the arc; its centre above the block's top (z = 0)
HALF = (0.015, 0.01, 0.005)


def quat(theta):
    """The needle's arc in the world x-z plane, turned by theta about its axis (-y)."""
    s, c = math.sin(math.pi / 4), math.cos(math.pi / 4)
    x2, y2, z2, w2 = 0.0, 0.0, math.sin(theta / 2), math.cos(theta / 2)
    return (c * x2 + s * w2, c * y2 - s * z2, c * z2 + s * y2, c * w2 - s * x2)


START = math.pi + math.asin(H / R) - 0.2 - A  # the tip 0.2 rad above where it meets the top


def scene(make_engine, envs=1, thread_length=0.06, gravity=(0, 0, 0), density=1140, strand=None, **needle):
    """The block, and per env a needle at START with its thread; `strand`: the thread's Strand arguments
    (default a 2-0 braid: a rod of the given density)."""
    world = cressim.World(cressim.SceneLayout(envs))
    mesh = cressim.TetMesh.box(HALF, (12, 8, 4))
    rest = np.asarray(mesh.positions)
    needles = []
    for env in range(envs):
        block = world.create_entity(env=env, name="tissue")
        block.add(cressim.Transform(position=(0, 0, -HALF[2])))
        block.add(cressim.SoftBody(mesh, fixed=np.nonzero(rest[:, 2] < -HALF[2] + 1e-6)[0], youngs_modulus=10e3,
                                   radius=0.0005, damping=5.0))
        tail = np.array([R * math.cos(START), 0, H + R * math.sin(START)])
        count = int(round(thread_length / 0.002)) + 1
        pts = tail + np.linspace(0, thread_length, count)[:, None] * np.array([-0.6, 0, 0.8])
        thread = world.create_entity(env=env, name="thread")
        strand = strand or {"youngs_modulus": 5e7, "density": density, "damping": 2.0}
        thread.add(cressim.Strand(pts.astype(np.float32), radius=0.00015, **strand))
        body = world.create_entity(env=env, name="needle")
        body.add(cressim.Transform(position=(0, 0, H), rotation=quat(START)))
        body.add(cressim.RigidBody(kinematic=True, mass=0.001, inertia=(1e-8, 1e-8, 1e-8)))
        body.add(cressim.Needle(thread=thread, arc_radius=R, arc_angle=A, **needle))
        needles.append(body)
    return start(world, make_engine, gravity=gravity), needles, len(rest)


def turn(engine, needles, to, rate=2.0, envs=None, centre=(0, 0, H), start=START):
    """Turns the needles (all, or those of `envs`) from `start` to `to` at `rate` rad/s."""
    dt = engine.physics.dt
    frames = int(round((to - start) / rate / dt))
    for f in range(frames):
        theta = start + (to - start) * (f + 1) / frames
        for e, needle in enumerate(needles):
            if envs is None or e in envs:
                needle.transform = cressim.Transform(position=centre, rotation=quat(theta))
        engine.step_physics()
        engine.end_frame()


def surface_crossings():
    """x of the two points where the arc meets the block's top (z = 0)."""
    return -math.sqrt(R * R - H * H), math.sqrt(R * R - H * H)


def test_a_needle_turned_along_its_arc_goes_in_and_out_and_leaves_the_tissue_in_place(make_engine):
    engine, needles, tissue = scene(make_engine)
    rest = positions(engine)[:tissue].copy()
    out = 2 * math.pi - math.asin(H / R) - 0.4
    turn(engine, needles, to=out)  # the tip out, the tail still in
    records = punctures(engine)[0]
    assert [r["state"] for r in records] == [PUNCTURED, PUNCTURED]
    entry, exit_ = sorted(records, key=lambda r: -r["s"])  # the entry is further along the path
    xs = surface_crossings()
    assert entry["point"][0] == pytest.approx(xs[0], abs=0.001) and abs(entry["point"][2]) < 0.001
    assert exit_["point"][0] == pytest.approx(xs[1], abs=0.001) and abs(exit_["point"][2]) < 0.001
    # the tissue stays where it was: the needle runs along its own path through it
    assert np.linalg.norm(positions(engine)[:tissue] - rest, axis=1).max() < 0.001
    # on through: the tail passes both, and the thread is drawn through
    turn(engine, needles, to=2 * math.pi + 0.5, start=out)
    records = punctures(engine)[0]
    assert len(records) == 2 and all(r["s"] > R * A for r in records)
    assert np.linalg.norm(positions(engine)[:tissue] - rest, axis=1).max() < 0.0015


def test_a_bite_on_tissue_moving_under_gravity_finds_both_crossings(make_engine):
    """Gravity (along +z, away from the top) on from the start sets the block bouncing (its top by up
    to 0.4 mm): where its top rose past the descending tip in a substep's solve, after that
    substep's crossing test, the entry was missed (the tip then lay below the surface at the next
    test's start). Both crossings are found, at the arc's crossings of the top."""
    engine, needles, tissue = scene(make_engine, gravity=(0, 0, 9.81))
    turn(engine, needles, to=2 * math.pi - math.asin(H / R) - 0.4)  # the tip out, the tail still in
    records = punctures(engine)[0]
    assert [r["state"] for r in records] == [PUNCTURED, PUNCTURED]
    entry, exit_ = sorted(records, key=lambda r: -r["s"])
    xs = surface_crossings()
    assert entry["point"][0] == pytest.approx(xs[0], abs=0.001)
    assert exit_["point"][0] == pytest.approx(xs[1], abs=0.001)


@pytest.mark.parametrize("force,depth,through", [(0.02, 0.05, "force"), (100.0, 0.001, "depth"), (100.0, 1.0, None)])
def test_the_surface_gives_way_at_the_puncture_force_or_depth(make_engine, force, depth, through):
    engine, needles, tissue = scene(make_engine, puncture_force=force, puncture_depth=depth)
    dt, pushes = engine.physics.dt, []
    theta = START
    for _ in range(int(0.6 / 2.0 / dt)):  # the tip 0.4 rad past the top: 3 mm in along the arc
        theta += 2.0 * dt
        needles[0].transform = cressim.Transform(position=(0, 0, H), rotation=quat(theta))
        engine.step_physics()
        engine.end_frame()
        pushes.append(float(engine.buffer("particles.needle_states").read()[0, 3]))
    records = punctures(engine)[0]
    assert len(records) == 1
    r = records[0]
    if through is None:  # neither reached: the tip pushes the surface ahead of it, 2-3 mm down
        assert r["state"] == INDENTING and -0.004 < r["point"][2] < -0.0015
        assert 0 < pushes[-1] < force
    else:
        assert r["state"] == PUNCTURED
        if through == "force":
            assert force <= r["push"] < 2 * force  # went through the substep it reached the force
        else:
            assert r["push"] < force
        assert max(pushes) < (2 * force if through == "force" else force)


def test_the_knot_does_not_pass_the_punctures_and_pulls_the_tissue(make_engine):
    engine, needles, tissue = scene(make_engine, thread_length=0.03)
    turn(engine, needles, to=2 * math.pi + 0.6)  # through; 30 mm of thread is not enough to clear the bite
    dt = engine.physics.dt
    centre = np.array([0.0, 0.0, H])
    theta = 2 * math.pi + 0.6
    for _ in range(180):  # on up and away, 30 mm
        centre = centre + np.array([0.0, 0.0, 0.01]) * dt
        needles[0].transform = cressim.Transform(position=tuple(centre), rotation=quat(theta))
        engine.step_physics()
        engine.end_frame()
    thread = positions(engine)[tissue:]
    length = np.linalg.norm(np.diff(thread, axis=0), axis=1).sum()
    # nearly inextensible through the punctures: the taut string gives T / (500 N/m) a span under
    # this kinematic yank (docs/particles.md, "Suturing")
    assert length == pytest.approx(0.03, rel=0.03)
    knot = [r for r in punctures(engine)[0] if r["knot"]]
    # the knot held the entry and drew it through the bite and up with the thread: they meet by
    # inverse mass, the thread (far lighter) giving most, so a kinematic pull does not tear the
    # tissue away; the knot stays within a few millimetres of the tissue it holds
    assert len(knot) >= 1
    for r in knot:
        assert np.linalg.norm(r["point"] - thread[-1]) < 0.004 and r["point"][2] > 0.003


def test_envs_sew_apart_and_an_env_reset_lets_go(make_engine):
    engine, needles, tissue = scene(make_engine, envs=2)
    turn(engine, needles, to=2 * math.pi - math.asin(H / R) - 0.4, envs=[0])
    first, second = punctures(engine)
    assert len(first) == 2 and second == []
    engine.reset_envs([0])
    engine.step_physics()
    engine.end_frame()
    assert punctures(engine) == [[], []]


def test_bad_needles_say_what_and_where(make_engine):
    def prepare(needle_kwargs, body=True, thread_env=0):
        world = cressim.World(cressim.SceneLayout(2))
        pts = np.stack([np.linspace(0, 0.02, 5), np.zeros(5), np.zeros(5)], 1)
        thread = world.create_entity(env=thread_env, name="thread")
        thread.add(cressim.Strand(pts))
        e = world.create_entity(env=0, name="needle")
        e.add(cressim.Transform())
        if body:
            e.add(cressim.RigidBody(kinematic=True, mass=0.001, inertia=(1e-8, 1e-8, 1e-8)))
        e.add(cressim.Needle(**{"thread": thread, **needle_kwargs}))
        make_engine(world).prepare()

    with pytest.raises(cressim.AuthoringError, match="'needle'.*Needle: needs a RigidBody"):
        prepare({}, body=False)
    with pytest.raises(cressim.AuthoringError, match="Needle.thread names entity 0 of env 1; a needle's thread is in its env"):
        prepare({}, thread_env=1)
    with pytest.raises(cressim.AuthoringError, match="Needle.arc_radius must be positive, got 0"):
        prepare({"arc_radius": 0.0})
    with pytest.raises(cressim.AuthoringError, match="Needle.friction must be >= 0, got -0.1"):
        prepare({"friction": -0.1})
    with pytest.raises(cressim.AuthoringError, match="Needle.puncture_force must be positive, got nan"):
        prepare({"puncture_force": float("nan")})
    with pytest.raises(cressim.AuthoringError, match="Needle.max_punctures must be at least 2, got 1"):
        prepare({"max_punctures": 1})
    with pytest.raises(cressim.AuthoringError, match="Needle.max_punctures is 65; at most 64"):
        prepare({"max_punctures": 65})
    with pytest.raises(cressim.AuthoringError, match="Needle.thread names entity 1, which has no Strand"):
        prepare({"thread": 1})


def test_the_suture_demo_bites_twice_and_pulls_the_stitch_tight(tmp_path):
    import json

    from cressim.demos.suture import run

    assert run(out_dir=str(tmp_path), images=2, width=96, height=72) == 0
    summary = json.loads((tmp_path / "suture_summary.json").read_text())
    bites = summary["punctures_after_each_bite"]
    # each bite crosses four surfaces (on an H100 too, since the thread no longer wrote env 0's
    # tissue when drawn back to the tail: 8 envs bit-identical through the whole demo)
    assert bites["bite1"] == bites["carry"] == 4 and bites["bite2"] == 8
    assert summary["knot_holds"] and summary["knot_caught_at_frame"] is not None
    # the loop left between the bites (about 110 mm) is drawn through: pulled to the demo's
    # tension, the thread runs from puncture to puncture within a few millimetres of straight,
    # keeps its length, and the wound narrows at both bites
    assert max(summary["slack_after_bites_mm"]) > 50
    assert all(abs(v) < 8 for v in summary["slack_tight_mm"]), summary["slack_tight_mm"]
    assert summary["tension_n"] == pytest.approx(summary["tension_target_n"], rel=0.1)
    assert summary["thread_length_mm"] == pytest.approx(summary["thread_rest_length_mm"], rel=0.01)
    assert all(after < before - 0.5 for before, after in zip(summary["gap_before_mm"], summary["gap_after_mm"]))
    assert summary["health_events"] == 0
    assert len(list(tmp_path.glob("suture_*_rgb.png"))) >= 3


def test_envs_of_the_demo_driven_alike_through_a_bite_stay_alike(make_engine):
    """Envs are independent: two envs of the demo's scene, their needles driven alike through the
    first bite, stay alike particle for particle, and the tissue far from the needle stays put.
    (The thread's draw once wrote global particle 0, env 0's, at the tail: a record slid back to
    the needle's length took the thread segment path_at gave it, NONE, and wrote NONE + 1.)"""
    from cressim.demos import suture as demo

    envs = 2
    world = cressim.World(cressim.SceneLayout(envs))
    meshes = {"table": world.add_mesh(cressim.Mesh.plane(0.1)),
              "needle": world.add_mesh(demo.needle_mesh(demo.RADIUS, demo.ANGLE, 0.00035))}
    needles = [demo.author_env(world, env, meshes, 32, 24, camera=False) for env in range(envs)]
    engine = make_engine(world)
    engine.prepare()
    engine.upload_world()
    m = engine.particle_mapping
    flaps = np.concatenate([np.arange(int(o), int(o) + int(c)) for e, o, c in
                            zip(m["object_entity"], m["object_offset"], m["object_count"])
                            if world.entity(int(e)).env == 0 and world.entity(int(e)).name.endswith("_flap")])
    start = positions(engine)
    far = flaps[np.hypot(start[flaps, 0], start[flaps, 1] - demo.BITES[0]) > 0.012]  # beyond the arc's reach
    for phase, centre, theta in demo.motion(engine.physics.dt):
        if phase != "bite1":
            break
        for needle in needles:
            needle.transform = cressim.Transform(position=tuple(centre), rotation=demo._quat(theta))
        engine.step_physics()
        engine.end_frame()
    p = positions(engine)
    first, second = punctures(engine)
    assert len(first) == len(second) == 4  # the bite went in and out of both flaps in both envs
    per_env = p.reshape(envs, -1, 3)
    assert np.abs(per_env[1] - per_env[0]).max() <= 1e-9
    assert np.linalg.norm(p[far] - start[far], axis=1).max() < 0.001
