"""Randomization of particle objects: an elastic soft body's drawn Young's modulus sets its static
sag (linear elasticity: sag x E constant, and the sag of a body authored with that modulus), its
drawn mass scale sags it as that times the density would; a particle object's drawn damping d
gives a falling particle the velocity of v <- (v + h g) / (1 + h d) per substep; each in its own
env only. A drawn stiffness scale divides the XPBD compliances: the expert model's cantilever
sags as one authored with them."""
import numpy as np

import cressim
from cressim.randomization import Randomizer

from .frames import randomized_frame

E, NU = 1e5, 0.3
HALF, CELLS = (0.03, 0.015, 0.015), (8, 2, 2)


def cantilevers(make_engine, moduli, density=None):
    """Per env a 60 x 30 x 30 mm cantilever clamped at x = -30 mm (env 1's has another name)."""
    mesh = cressim.TetMesh.box(HALF, CELLS)
    rest = np.asarray(mesh.positions)
    world = cressim.World(cressim.SceneLayout(len(moduli)))
    for env, youngs_modulus in enumerate(moduli):
        body = world.create_entity(env=env, name="tissue" if env != 1 else "other_tissue")
        body.add(cressim.Transform(position=(0, 0, 1)))
        body.add(cressim.SoftBody(mesh, fixed=np.nonzero(rest[:, 0] < -HALF[0] + 1e-6)[0],
                                  youngs_modulus=float(youngs_modulus), poisson_ratio=NU,
                                  density=float(density[env]) if density else 1000.0, damping=5.0))
    engine = make_engine(world)
    engine.prepare()
    engine.upload_world()
    return engine, rest


def sags(engine, rest, envs, frames=180):
    for _ in range(frames):
        engine.step_physics()
        engine.end_frame()
    z = engine.buffer("particles.positions").read()[:, 2].reshape(envs, -1)
    tip = rest[:, 0] > HALF[0] - 1e-6
    return 1 - z[:, tip].mean(axis=1)


def test_youngs_modulus_sets_each_envs_sag(make_engine):
    engine, rest = cantilevers(make_engine, [E] * 3)
    r = Randomizer(engine, [dict(param="youngs_modulus", entity="tissue", distribution="log_uniform",
                                 range=[2e5, 5e5], operation="abs")], seed=3)
    randomized_frame(engine, r, reset_all=True, physics=False)
    drawn = r.read("youngs_modulus/tissue")[:, 0]
    sag = sags(engine, rest, 3)
    moduli = [drawn[0], E, drawn[2]]  # env 1's body is not randomized
    reference = sags(*cantilevers(make_engine, moduli), 3)
    np.testing.assert_allclose(sag, reference, rtol=2e-3)
    # small strains: the sag goes as 1 / E
    np.testing.assert_allclose(sag * np.array(moduli), sag[1] * E, rtol=0.03)
    assert drawn[0] != drawn[2]  # and both at least twice env 1's modulus: the sags differ


def test_particle_damping_sets_each_envs_fall(make_engine):
    world = cressim.World(cressim.SceneLayout(3))
    for env in range(3):
        drop = world.create_entity(env=env, name="drop")
        drop.add(cressim.Transform(position=(0, 0, 10)))
        drop.add(cressim.Fluid(np.zeros((1, 3), np.float32), radius=0.01, viscosity=0.0))
    engine = make_engine(world)
    settings = cressim.PhysicsSettings(dt=1 / 60, substeps=4)
    engine.physics = settings
    engine.prepare()
    engine.upload_world()
    r = Randomizer(engine, [dict(param="damping", entity="drop", range=[0.5, 5.0], operation="abs")], seed=1)
    randomized_frame(engine, r, reset_all=True, physics=False)
    d = r.read("damping/drop")[:, 0]
    objects = engine.buffer("particles.objects").read().view(np.float32).reshape(3, -1)
    np.testing.assert_allclose(objects[:, 10], d, rtol=1e-6)  # ParticleObject.material.z
    frames = 30
    for _ in range(frames):
        engine.step_physics()
        engine.end_frame()
    v = engine.buffer("particles.velocities").read()[:, 2]
    h, g = settings.dt / settings.substeps, settings.gravity[2]
    expected = np.zeros(3)
    for _ in range(frames * settings.substeps):
        expected = (expected + h * g) / (1 + h * d)
    np.testing.assert_allclose(v, expected, rtol=1e-3)


def test_soft_body_mass_sets_each_envs_sag_as_its_density_would(make_engine):
    # the sag of a cantilever under its own weight goes with its density: a drawn mass scale s
    # sags as a body authored with s times the density
    engine, rest = cantilevers(make_engine, [E] * 3)
    r = Randomizer(engine, [dict(param="mass", entity="tissue", range=[0.5, 2.0], operation="scale")], seed=1)
    randomized_frame(engine, r, reset_all=True, physics=False)
    scale = r.read("mass/tissue")[:, 0]
    sag = sags(engine, rest, 3)
    w = engine.buffer("particles.positions").read()[:, 3].reshape(3, -1)
    w0 = engine.buffer("particles.initial_positions").read()[:, 3].reshape(3, -1)
    free = w0[0] > 0
    np.testing.assert_allclose(w[0, free], w0[0, free] / scale[0], rtol=1e-6)
    np.testing.assert_array_equal(w[1], w0[1])  # env 1's body is not randomized
    reference = sags(*cantilevers(make_engine, [E] * 3, density=[1000.0 * scale[0], 1000.0, 1000.0 * scale[2]]), 3)
    np.testing.assert_allclose(sag, reference, rtol=2e-3)
    np.testing.assert_allclose(sag / np.array([scale[0], 1.0, scale[2]]), sag[1], rtol=0.03)  # linear: sag ~ density


def xpbd_cantilevers(make_engine, scales):
    """Per env the cantilever of the expert model (XPBD distance and volume constraints), its
    compliances divided by `scales` (env 1's body has another name)."""
    mesh = cressim.TetMesh.box(HALF, CELLS)
    rest = np.asarray(mesh.positions)
    world = cressim.World(cressim.SceneLayout(len(scales)))
    for env, s in enumerate(scales):
        body = world.create_entity(env=env, name="tissue" if env != 1 else "other_tissue")
        body.add(cressim.Transform(position=(0, 0, 1)))
        body.add(cressim.SoftBody(mesh, fixed=np.nonzero(rest[:, 0] < -HALF[0] + 1e-6)[0], mass=0.001,
                                  distance_compliance=20.0 / float(s), volume_compliance=20.0 / float(s), damping=5.0))
    engine = make_engine(world)
    engine.prepare()
    engine.upload_world()
    return engine, rest


def test_stiffness_divides_xpbd_compliances(make_engine):
    engine, rest = xpbd_cantilevers(make_engine, [1.0] * 3)
    r = Randomizer(engine, [dict(param="stiffness", entity="tissue", distribution="log_uniform", range=[0.2, 5.0],
                                 operation="scale")], seed=3)
    randomized_frame(engine, r, reset_all=True, physics=False)
    s = r.read("stiffness/tissue")[:, 0]
    sag = sags(engine, rest, 3, frames=120)
    reference = sags(*xpbd_cantilevers(make_engine, [s[0], 1.0, s[2]]), 3, frames=120)
    np.testing.assert_allclose(sag, reference, rtol=1e-3)
    # stiffer sags less, softer more, than env 1's body
    assert all((sag[k] < sag[1]) == (s[k] > 1) and abs(sag[k] / sag[1] - 1) > 0.05 for k in (0, 2)), (s, sag)
