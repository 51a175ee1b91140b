"""Heat in elastic bodies (cressim.Thermal): conduction through the tets against the heat
equation's analytic solution, a heat source's energy, the Arrhenius damage integral, per-env
sources and resets, and checked inputs."""
import math

import numpy as np
import pytest

import cressim

from .particle_scenes import start, step

RHO, C = 1000.0, 3540.0  # kg/m^3, J/kg/K
GAS = 8.314462618


def _bodies(make_engine, mesh, envs=2, dt=1 / 60, **thermal):
    world = cressim.World(cressim.SceneLayout(envs))
    for env in range(envs):
        body = world.create_entity(env=env, name="tissue")
        body.add(cressim.Transform(position=(0, 0, 1)))
        body.add(cressim.SoftBody(mesh, youngs_modulus=1e4, density=RHO, radius=0.001,
                                  thermal=cressim.Thermal(specific_heat=C, **thermal)))
    return start(world, make_engine, dt=dt, substeps=1, gravity=(0, 0, 0))


def _capacities(engine, envs):
    return engine.buffer("particles.heat_capacities").read().reshape(envs, -1)


def test_a_cosine_profile_decays_as_the_heat_equation_says(make_engine):
    """A 40 mm bar, insulated (nothing leaves it), starts at 37 C + 10 K cos(pi x / L): the 1-D heat
    equation keeps the profile and scales it by exp(-alpha (pi / L)^2 t), alpha = k / (rho c)."""
    L, k = 0.04, 52.0  # a conductivity that lets the profile decay within seconds
    mesh = cressim.TetMesh.box((L / 2, 0.001, 0.001), (20, 1, 1))
    engine = _bodies(make_engine, mesh, envs=1, dt=0.1, conductivity=k)
    x = np.asarray(mesh.positions)[:, 0] + L / 2
    mode = np.cos(math.pi * x / L)
    engine.buffer("control.particle_reset_temperatures").write((310.15 + 10 * mode).astype(np.float32))
    engine.reset_envs([0])  # the starting field, from the next step on
    step(engine, 1)
    temperatures = engine.buffer("particles.temperatures")
    m = _capacities(engine, 1)[0]

    def amplitude():
        t = temperatures.read()
        return np.sum(m * (t - np.sum(m * t) / m.sum()) * mode) / np.sum(m * mode ** 2)

    a0 = amplitude()
    seconds = 9.9
    step(engine, 99)
    expected = math.exp(-k / (RHO * C) * (math.pi / L) ** 2 * seconds)  # 0.40
    assert abs(amplitude() / a0 - expected) < 0.01 * expected, (amplitude() / a0, expected)  # 0.13 % off
    mean = np.sum(m * temperatures.read()) / m.sum()
    assert abs(mean - 310.15) < 1e-3  # insulated: the heat stays


@pytest.mark.parametrize("centre", [(0, 0, 1), (0, 0, 1.005)])
def test_a_source_puts_its_power_into_the_tissue_it_covers(make_engine, centre):
    """1 W for one second from a 3 mm source in the middle of a 10 mm cube, or on the middle of its
    top face (half its sphere in air): either way the body's heat rises by 1 J, every joule kept
    (conduction moves heat, it does not make or lose it), shared among the covered particles by
    volume; env 1, its source off, stays at 37 C."""
    mesh = cressim.TetMesh.box((0.005, 0.005, 0.005), (4, 4, 4))
    engine = _bodies(make_engine, mesh)
    sources = np.zeros((2, 2, 4), np.float32)
    sources[0, 0] = (*centre, 0.003)
    sources[0, 1, 0] = 1.0
    engine.buffer("control.heat_sources").write(sources)
    step(engine, 60)
    t = engine.buffer("particles.temperatures").read().reshape(2, -1)
    m = _capacities(engine, 2)
    x = engine.buffer("particles.positions").read()[:, :3].reshape(2, -1, 3)
    covered = np.linalg.norm(x[0] - centre, axis=1) < 0.003
    heat = np.sum(m[0] * (t[0] - 310.15))
    assert covered.any() and abs(heat - 1.0) < 1e-3, heat
    assert t[0].max() > 310.15 + 0.1 and np.abs(t[1] - 310.15).max() < 1e-4
    assert np.abs(engine.buffer("particles.damage").read().reshape(2, -1)[1]).max() < 1e-6


def test_damage_follows_the_arrhenius_integral_and_resets_with_its_env(make_engine):
    """Tissue held at 70 C (uniform, no source: it stays there) is damaged at A exp(-Ea / (R T))
    per second, 4.4 /s with the liver pair: coagulated (Omega > 1) within a quarter second; a reset
    of env 0 brings its particles back to 70 C and no damage, env 1 keeps its own."""
    mesh = cressim.TetMesh.box((0.005, 0.005, 0.005), (2, 2, 2))
    T = 343.15
    engine = _bodies(make_engine, mesh, temperature=T)
    frames = 15
    step(engine, frames)
    rate = 7.39e39 * math.exp(-2.577e5 / (GAS * T))
    damage = engine.buffer("particles.damage").read()
    np.testing.assert_allclose(damage, rate * frames / 60, rtol=1e-3)
    assert damage.min() > 1.0
    engine.reset_envs([0])
    step(engine, 1)
    damage = engine.buffer("particles.damage").read().reshape(2, -1)
    np.testing.assert_allclose(damage[0], rate / 60, rtol=1e-3)  # one frame since the reset
    np.testing.assert_allclose(damage[1], rate * (frames + 1) / 60, rtol=1e-3)
    np.testing.assert_allclose(engine.buffer("particles.temperatures").read(), T, atol=1e-3)


def test_thermal_inputs_are_checked(make_engine):
    mesh = cressim.TetMesh.box((0.005, 0.005, 0.005), (1, 1, 1))
    world = cressim.World(cressim.SceneLayout(1))
    world.create_entity(env=0, name="liver").add(cressim.SoftBody(
        mesh, youngs_modulus=1e4, thermal=cressim.Thermal(conductivity=-1.0)))
    with pytest.raises(cressim.AuthoringError, match=r"'liver' in env 0: SoftBody.thermal.conductivity must be positive, got -1"):
        make_engine(world).prepare()
    world = cressim.World(cressim.SceneLayout(1))
    world.create_entity(env=0, name="sponge").add(cressim.SoftBody(
        mesh, distance_compliance=1e-4, thermal=cressim.Thermal()))
    with pytest.raises(cressim.AuthoringError, match=r"'sponge' in env 0: SoftBody.thermal needs the elastic material"):
        make_engine(world).prepare()


def test_an_energized_tool_heats_the_tissue_it_touches(make_engine):
    """cressim.passes.Cautery on a kinematic tool resting its tip on a 10 mm cube: 30 W into the
    tissue within 2 mm of the tip for half a second coagulates it there (Omega > 1, above 60 C)
    and leaves the far side near 37 C; env 1's tool, off, heats nothing; switched off, the heat
    spreads and the peak falls."""
    from cressim.passes.cautery import Cautery

    mesh = cressim.TetMesh.box((0.005, 0.005, 0.005), (5, 5, 5))
    world = cressim.World(cressim.SceneLayout(2))
    tools = []
    for env in range(2):
        body = world.create_entity(env=env, name="tissue")
        body.add(cressim.Transform(position=(0, 0, 1)))
        body.add(cressim.SoftBody(mesh, youngs_modulus=1e4, radius=0.001, thermal=cressim.Thermal()))
        tool = world.create_entity(env=env, name="hook")
        tool.add(cressim.Transform(position=(0, 0, 1.005)))  # on the top face's middle
        tool.add(cressim.RigidBody(kinematic=True, mass=0.01, inertia=(1e-6, 1e-6, 1e-6)))
        tools.append(tool)
    engine = start(world, make_engine, gravity=(0, 0, 0))
    with pytest.raises(ValueError, match="power of env 1 must be finite and >= 0, got -1"):
        Cautery(engine, tools, (0, 0, 0), 0.002, power=[30.0, -1.0])
    cautery = Cautery(engine, tools, (0, 0, 0), 0.002, power=30.0)
    cautery.set([True, False])
    for _ in range(30):
        cautery.execute()
        step(engine, 1)
    t = engine.buffer("particles.temperatures").read().reshape(2, -1)
    damage = engine.buffer("particles.damage").read().reshape(2, -1)
    x = engine.buffer("particles.positions").read()[:, :3].reshape(2, -1, 3)
    near = np.linalg.norm(x[0] - [0, 0, 1.005], axis=1) < 0.002
    far = x[0, :, 2] < 1 - 0.004
    assert near.any() and t[0, near].min() > 333.15 and damage[0, near].min() > 1.0, (t[0, near], damage[0, near])
    assert t[0, far].max() < 311.15 and damage[0, far].max() == 0
    assert np.abs(t[1] - 310.15).max() < 1e-4 and damage[1].max() == 0
    peak = t[0].max()
    cautery.set([False, False])
    for _ in range(30):
        cautery.execute()
        step(engine, 1)
    assert engine.buffer("particles.temperatures").read().reshape(2, -1)[0].max() < peak


def _blocks(make_engine, hot, floor, envs=2, **thermal):
    """A 40 mm cube of 20 kPa tissue with heat in each env (on a frictionless floor, or floating
    without gravity), env 0's starting at `hot` K everywhere (coagulated within a frame), env 1's
    at 37 C."""
    mesh = cressim.TetMesh.box((0.02, 0.02, 0.02), (3, 3, 3))
    world = cressim.World(cressim.SceneLayout(envs))
    for env in range(envs):
        if floor:
            world.create_entity(env=env, name="floor").add(cressim.Collider(cressim.Shape.plane()))
        block = world.create_entity(env=env, name="tissue")
        block.add(cressim.Transform(position=(0, 0, 0.022)))
        block.add(cressim.SoftBody(mesh, youngs_modulus=2e4, density=RHO, radius=0.002, friction=0.0, damping=5.0,
                                   thermal=cressim.Thermal(**thermal)))
    engine = start(world, make_engine, **({} if floor else {"gravity": (0, 0, 0)}))
    t = engine.buffer("control.particle_reset_temperatures").read().reshape(envs, -1)
    t[0] = hot
    engine.buffer("control.particle_reset_temperatures").write(t.reshape(-1))
    engine.reset_envs([0])
    return engine, np.asarray(mesh.positions), np.asarray(mesh.tets)


def test_coagulated_tissue_shrinks(make_engine):
    """Coagulated through (Omega >> 1), a floating block shrinks by the linear strain 0.1 in every
    direction: its volume falls to 0.9^3 = 0.729 of the raw block's."""
    engine, rest, tets = _blocks(make_engine, 373.15, floor=False)
    step(engine, 90)
    x = engine.buffer("particles.positions").read()[:, :3].reshape(2, -1, 3)
    assert engine.buffer("particles.damage").read().reshape(2, -1)[0].min() > 10

    def volume(p):
        a, b, c, d = (p[tets[:, k]] for k in range(4))
        return np.einsum("ij,ij->i", b - a, np.cross(c - a, d - a)).sum() / 6

    ratio = volume(x[0]) / volume(x[1])
    assert abs(ratio - 0.729) < 0.01, ratio


def test_coagulated_tissue_stiffens(make_engine):
    """A block resting on a floor sinks under its weight by rho g H^2 / 2E: coagulated, 4 times
    stiffer (shrinkage off here), it sinks a quarter as far as the raw block beside it."""
    engine, rest, _ = _blocks(make_engine, 373.15, floor=True, coagulated_shrinkage=0.0)
    step(engine, 240)
    top = rest[:, 2] > 0.02 - 1e-6
    z = engine.buffer("particles.positions").read()[:, 2].reshape(2, -1)
    drop = 0.04 + 0.002 - z[:, top].mean(axis=1)
    assert 3e-4 < drop[1] < 5e-4, drop  # the raw block, as tests/physics/test_elastic_tets.py's
    assert abs(drop[0] / drop[1] - 0.25) < 0.03, drop


def test_an_energized_tool_cuts_coagulated_tissue(make_engine):
    """With the heat source on in cut mode at the coagulated block's top middle, the coagulated
    tets whose centres lie within its 8 mm radius are cut, the rest stay; the raw block in env 1,
    under the same source, is only heated, not cut (its tissue is not coagulated yet); in
    coagulation mode nothing is cut."""
    engine, rest, tets = _blocks(make_engine, 373.15, floor=False)
    step(engine, 2)
    sources = np.zeros((2, 2, 4), np.float32)
    sources[:, 0] = (0, 0, 0.042, 0.008)
    sources[:, 1, 0] = 1.0
    engine.buffer("control.heat_sources").write(sources)  # coagulation mode
    step(engine, 1)
    assert not engine.buffer("control.particle_tet_cut").read().any()
    sources[:, 1, 1] = 1.0  # cut mode
    engine.buffer("control.heat_sources").write(sources)
    step(engine, 1)
    cut = engine.buffer("control.particle_tet_cut").read().reshape(2, -1)
    x = engine.buffer("particles.positions").read()[:, :3].reshape(2, -1, 3)
    centres = x[0][tets].mean(axis=1)
    inside = np.linalg.norm(centres - [0, 0, 0.042], axis=1) < 0.008
    assert inside.any() and np.array_equal(cut[0] != 0, inside)
    assert not cut[1].any()


def test_the_cautery_demo_coagulates_and_cuts_a_track(tmp_path):
    """`cressim demo cautery`, shortened (1 s out in coagulation mode, 1 s back in cut mode): a
    coagulated track, cut on the way back, its images saved."""
    import json

    from cressim import io
    from cressim.demos.cautery import run

    assert run(frames=120, out_dir=str(tmp_path), images=2, width=64, height=48) == 0
    summary = json.loads((tmp_path / "cautery_summary.json").read_text())
    assert summary["coagulated_mm3_per_env"] > 20 and summary["cut_tets_per_env"] > 0, summary
    assert 60 < summary["peak_c"] < 300 and summary["health_events"] == 0
    assert io.read_png(tmp_path / "cautery_119_rgb.png").shape[:2] == (48, 64)
