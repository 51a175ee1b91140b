"""Routed cables: a cable-driven continuum robot, a rod of a material (Strand youngs_modulus)
with spacer disks and tendons through their holes (cressim.Tendons), at the default settings (4
substeps x 4 iterations at 60 Hz). Checked against the constant-curvature model (a tendon pulled
in by d at offset r turns the tip by d / r) and the planar elastica (elastica.py) for the tip
under a load and under a tendon's tension."""
import math

import numpy as np
import pytest

import cressim
from cressim.tendons import TendonDrive

from cressim.demos.elastica import cantilever_tip
from .particle_scenes import positions, start, step

LENGTH, OFFSET = 0.1, 0.004  # m: the backbone, the tendons' offset from it
NITINOL = {"youngs_modulus": 50e9, "density": 6450, "radius": 0.0005}  # a 1 mm superelastic NiTi backbone


def robot(make_engine, count=21, holes=((OFFSET, 0),), envs=1, material=NITINOL, every=2):
    """A straight backbone along +x at z = 0.5, clamped at its first segment (particles 0 and 1),
    disks at every `every`-th particle and the tip, in zero gravity."""
    s = np.linspace(0, LENGTH, count)
    pts = np.stack([s, 0 * s, np.full(count, 0.5)], 1).astype(np.float32)
    disks = list(range(0, count, every)) + ([count - 1] if (count - 1) % every else [])
    world = cressim.World(cressim.SceneLayout(envs))
    for env in range(envs):
        e = world.create_entity(env=env, name="robot")
        e.add(cressim.Strand(pts, fixed=[0, 1], damping=20, **material))
        e.add(cressim.Tendons(disks, np.asarray(holes, np.float32)))
    return start(world, make_engine, gravity=(0, 0, 0))


def rotate(q, v):
    u, w = q[:3], q[3]
    t = 2 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def tip_turn(engine, env=0, envs=1):
    """The turn of the tip's frame from the clamped base's (rad) and the axis it turns about."""
    q = engine.buffer("particles.orientations").read().reshape(envs, -1, 4)[env]
    base, tip = rotate(q[0], np.array([0, 0, 1.0])), rotate(q[-1], np.array([0, 0, 1.0]))
    axis = np.cross(base, tip)
    return math.atan2(np.linalg.norm(axis), base @ tip), axis / max(np.linalg.norm(axis), 1e-12)


def bends(engine):
    """The turn at each free joint (between neighbouring segments), rad."""
    p = positions(engine)
    d = np.diff(p, axis=0)
    d /= np.linalg.norm(d, axis=1)[:, None]
    return np.arccos(np.clip((d[:-1] * d[1:]).sum(1), -1, 1))


@pytest.mark.parametrize("count,material", [(21, NITINOL), (41, NITINOL),
                                            (21, {"youngs_modulus": 1e6, "density": 1100, "radius": 0.001})])
def test_a_pulled_tendon_bends_the_robot_by_displacement_over_offset(make_engine, count, material):
    engine = robot(make_engine, count, material=material)
    drive = TendonDrive(engine)
    for d in (0.001, 0.003):
        drive.pull(d)
        step(engine, 240)
        turn, axis = tip_turn(engine)
        # constant curvature: the tip turns d / r (measured 0.996 of it at 21 and 41 particles, from
        # 10 kPa to 50 GPa), toward the tendon's side (its hole is on the disks' -z side here)
        assert turn == pytest.approx(d / OFFSET, rel=0.02)
        assert positions(engine)[-1, 2] < 0.5 and abs(axis[1]) > 0.999
        b = bends(engine)[1:]  # the clamp's own joint aside
        assert b.max() - b.min() < 0.1 * b.mean()  # the same curvature all along
        assert drive.lengths()[0, 0] == pytest.approx(drive.rest_lengths[0, 0] - d, abs=2e-5)
        assert drive.tensions()[0, 0] > 0


def test_the_bending_plane_follows_the_tendons(make_engine):
    # four tendons at 90 degrees in antagonistic pairs: pulling one in lets its opposite out by as
    # much (held at its rest length it would stop the bend). The one at the disks' +y bends the
    # robot about its frame's x; pulled with the +x one by d / sqrt(2) each, diagonally, by as much
    holes = [(OFFSET, 0), (0, OFFSET), (-OFFSET, 0), (0, -OFFSET)]
    engine = robot(make_engine, holes=holes)
    drive = TendonDrive(engine)
    d = 0.002
    drive.pull([0, d, 0, -d])
    step(engine, 240)
    turn, axis = tip_turn(engine)
    assert turn == pytest.approx(d / OFFSET, rel=0.02)
    assert abs(axis[2]) > 0.999  # the frame's x is world -z here: the robot turns in the horizontal plane
    a = d / math.sqrt(2)
    drive.pull([a, a, -a, -a])
    step(engine, 240)
    turn, axis = tip_turn(engine)
    assert turn == pytest.approx(d / OFFSET, rel=0.02)
    assert abs(abs(axis[1]) - abs(axis[2])) < 0.02  # half way between the two planes
    # all slack: the robot's own stiffness takes it back straight
    drive.slack()
    step(engine, 240)
    assert tip_turn(engine)[0] < 1e-3 and np.allclose(drive.tensions(), 0)


@pytest.mark.parametrize("load", [0.02, 0.2])
def test_the_tip_under_a_load_follows_the_elastica(make_engine, load):
    # tendons slack, a dead load at the tip: small (Euler-Bernoulli) and large deflection
    engine = robot(make_engine)
    TendonDrive(engine).slack()
    forces = np.zeros((21, 4), np.float32)
    forces[-1, 2] = -load
    engine.buffer("control.particle_forces").write(forces)
    step(engine, 300)
    p = positions(engine)
    EI = NITINOL["youngs_modulus"] * math.pi * NITINOL["radius"] ** 4 / 4
    ref = cantilever_tip(LENGTH - LENGTH / 20, EI, load=load)  # from the clamp (particle 1)
    tip = p[-1] - p[1]
    assert tip[2] == pytest.approx(ref[1], rel=0.02)  # measured 0.998 and 1.000 of the drop
    assert tip[0] == pytest.approx(ref[0], rel=0.01)


def test_the_elastica_reference_is_bisshopp_and_druckers():
    # P L^2 / EI = 1: the tip drops 0.3017 L and comes in 0.0564 L (Bisshopp & Drucker 1945)
    x, z = cantilever_tip(1.0, 1.0, load=1.0)
    assert z == pytest.approx(-0.3017, abs=2e-4) and x == pytest.approx(1 - 0.0564, abs=2e-4)


@pytest.mark.parametrize("tension,load", [(2.0, 0.0), (2.0, 0.1)])
def test_a_tendons_tension_bends_the_robot_as_its_moment_does(make_engine, tension, load):
    # tension mode: the tendon's moment T r all along (plus a tip load); the discrete rod bends from
    # the clamp's joint half a segment early, an O(segment / length) excess: 41 particles
    engine = robot(make_engine, count=41, every=4)
    TendonDrive(engine).tension(tension)
    forces = np.zeros((41, 4), np.float32)
    forces[-1, 2] = -load
    engine.buffer("control.particle_forces").write(forces)
    step(engine, 300)
    p = positions(engine)
    EI = NITINOL["youngs_modulus"] * math.pi * NITINOL["radius"] ** 4 / 4
    ref = cantilever_tip(LENGTH - LENGTH / 40, EI, moment=tension * OFFSET, load=load)
    tip = p[-1] - p[1]
    assert tip[2] == pytest.approx(ref[1], rel=0.04)  # measured 1.025 of the drop (tension alone)
    assert tip[0] == pytest.approx(ref[0], rel=0.01)
    assert TendonDrive(engine).tensions()[0, 0] == pytest.approx(tension)


def test_envs_are_driven_apart_and_reset_alone(make_engine):
    engine = robot(make_engine, envs=2)
    drive = TendonDrive(engine)
    drive.pull([[0.002], [0.0]])
    step(engine, 120)
    p = positions(engine).reshape(2, -1, 3)
    assert p[0, -1, 2] < 0.49 and abs(p[1, -1, 2] - 0.5) < 1e-5  # env 1 held straight
    assert tip_turn(engine, 0, 2)[0] == pytest.approx(0.5, rel=0.02)
    engine.reset_envs([0])
    drive.pull([[0.0], [0.0]])
    step(engine, 1)
    assert positions(engine).reshape(2, -1, 3)[0, -1, 2] == pytest.approx(0.5, abs=1e-4)


def test_bad_tendons_say_what_and_where(make_engine):
    pts = np.stack([np.linspace(0, 0.1, 5), np.zeros(5), np.zeros(5)], 1)

    def prepare(*components):
        world = cressim.World(cressim.SceneLayout(1))
        e = world.create_entity(env=0, name="robot")
        for c in components:
            e.add(c)
        make_engine(world).prepare()

    with pytest.raises(cressim.AuthoringError, match="'robot'.*Tendons: needs a Strand"):
        prepare(cressim.Tendons([0, 4], [[0.004, 0]]))
    with pytest.raises(cressim.AuthoringError, match=r"Tendons.disks\[1\] names particle 7 of the Strand's 5"):
        prepare(cressim.Strand(pts, **NITINOL), cressim.Tendons([0, 7], [[0.004, 0]]))
    with pytest.raises(cressim.AuthoringError, match=r"Tendons.disks\[2\] must be above the disk before it"):
        prepare(cressim.Strand(pts, **NITINOL), cressim.Tendons([0, 3, 2], [[0.004, 0]]))
    with pytest.raises(cressim.AuthoringError, match=r"Tendons.holes\[0\] must be finite"):
        prepare(cressim.Strand(pts, **NITINOL), cressim.Tendons([0, 4], [[np.nan, 0]]))
    with pytest.raises(ValueError, match=r"Tendons holes: give an \(n, 2\) array"):
        cressim.Tendons([0, 4], [0.004, 0, 0])
    with pytest.raises(ValueError, match="give either youngs_modulus.*or mass and compliances"):
        cressim.Strand(pts, youngs_modulus=1e9, bend_compliance=1e-3)
    with pytest.raises(cressim.AuthoringError, match="Strand.poisson_ratio must be in"):
        prepare(cressim.Strand(pts, youngs_modulus=1e9, poisson_ratio=0.7))


def test_the_drive_checks_its_commands(make_engine):
    engine = robot(make_engine, envs=2, holes=[(OFFSET, 0), (-OFFSET, 0)])
    drive = TendonDrive(engine)
    with pytest.raises(ValueError, match="env 1 tendon 0 must be finite"):
        drive.pull([[0, 0], [np.nan, 0]])
    with pytest.raises(ValueError, match="env 0 tendon 1 must be >= 0 N"):
        drive.tension([1.0, -1.0])
    with pytest.raises(ValueError, match="is not shorter than its rest length"):
        drive.pull([0.2, 0])
    with pytest.raises(ValueError, match=r"one per tendon \(2\) or \(envs, tendons\) = \(2, 2\)"):
        drive.pull([0.001, 0.001, 0.001])
    assert (engine.buffer("control.tendon_commands").read()[:, 0] == 1).all()  # nothing written: held


def test_an_elastic_tendon_stretches_by_its_tension_over_its_stiffness(make_engine):
    # EA = 50 N (a soft polymer cord): pulled in 3 mm against the rod, it is longer than its target
    # by T L / EA, so the robot turns less than d / r by that much
    s = np.linspace(0, LENGTH, 21)
    world = cressim.World(cressim.SceneLayout(1))
    e = world.create_entity(env=0, name="robot")
    e.add(cressim.Strand(np.stack([s, 0 * s, np.full(21, 0.5)], 1).astype(np.float32), fixed=[0, 1], damping=20,
                         **NITINOL))
    e.add(cressim.Tendons(list(range(0, 21, 2)), [[OFFSET, 0]], stiffness=50.0))
    engine = start(world, make_engine, gravity=(0, 0, 0))
    drive = TendonDrive(engine)
    drive.pull(0.003)
    step(engine, 240)
    tension, length = drive.tensions()[0, 0], drive.lengths()[0, 0]
    stretch = length - (drive.rest_lengths[0, 0] - 0.003)
    assert tension > 0.5 and stretch == pytest.approx(tension * drive.rest_lengths[0, 0] / 50.0, rel=0.02)
    assert tip_turn(engine)[0] == pytest.approx((0.003 - stretch) / OFFSET, rel=0.02)


def test_the_cable_demo_bends_sweeps_and_carries_a_load(tmp_path):
    import json

    from cressim.demos.cable import run

    assert run(out_dir=str(tmp_path)) == 0
    summary = json.loads((tmp_path / "cable_summary.json").read_text())
    assert summary["health_events"] == 0
    for turn in summary["turns_rad"].values():
        assert turn["measured"] == pytest.approx(turn["d_over_r"], rel=0.02)
    assert 30 < summary["sweep_radius_mm"] < 40  # a 0.75 rad bend of a 0.1 m arc: about 36 mm off the axis
    for row in summary["tension"].values():
        assert np.allclose(row["tip_mm"], row["elastica_mm"], rtol=0.06)  # 21 particles: O(segment) excess
    assert (tmp_path / "cable_curvature.png").stat().st_size > 10000
    assert len(list(tmp_path.glob("cable_*_rgb.png"))) >= 6
