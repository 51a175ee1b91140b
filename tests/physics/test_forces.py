"""Forces read from the solver's buffers (N and N m, world frame, frame averages): a resting
box's contact force is its weight, a hanging body's joint force is its weight, and particles
pressing on bodies report what they exert (a kinematic plate under a soft cube, a dynamic box
lying on one)."""
import numpy as np
import pytest

import cressim

from .particle_scenes import static
from .scenes import box, ground, start, step

G = 9.81


def test_resting_box_contact_force_is_its_weight(make_engine):
    world = cressim.World(cressim.SceneLayout(1))
    ground(world, 0)
    box(world, 0, (0, 0, 0.1), mass=2.0)
    engine = start(world, make_engine)
    step(engine, 60)
    f = engine.buffer("rigid.contact_forces").read()[0, :3]
    torque = engine.buffer("rigid.contact_torques").read()[0, :3]
    np.testing.assert_allclose(f, [0, 0, 2.0 * G], rtol=0.01, atol=0.01 * 2.0 * G)
    assert np.abs(torque).max() < 1e-3 * 2.0 * G  # no turning moment about its centre


def test_hanging_body_joint_force_is_its_weight(make_engine):
    world = cressim.World(cressim.SceneLayout(1))
    bob = world.create_entity(env=0, name="bob")
    bob.add(cressim.Transform(position=(0, 0, -0.5)))
    bob.add(cressim.RigidBody(mass=1.5))
    bob.add(cressim.Collider(cressim.Shape.box((0.02, 0.02, 0.5)), mask=0))
    world.create_entity(env=0).add(cressim.Joint("ball", body_b=bob, anchor=(0, 0, 0)))
    engine = start(world, make_engine)
    step(engine, 60)
    f = engine.buffer("joint.reaction_forces").read()[0, :3]
    torque = engine.buffer("joint.reaction_torques").read()[0, :3]
    np.testing.assert_allclose(f, [0, 0, 1.5 * G], rtol=0.01, atol=0.01 * 1.5 * G)
    assert np.abs(torque).max() < 1e-6  # a ball joint transmits no moment


def soft_cube(world, r=0.025, elastic=False):
    """A 0.2 m cube of 125 particles on z = 0: XPBD constraints, 10 g a particle (1.25 kg), or an
    elastic one of 20 kPa (8 kg)."""
    cube = world.create_entity(env=0, name="cube")
    cube.add(cressim.Transform(position=(0, 0, 0.1 + r)))
    mesh = cressim.TetMesh.box((0.1, 0.1, 0.1), (4, 4, 4))
    if elastic:
        cube.add(cressim.SoftBody(mesh, radius=r, youngs_modulus=2e4, density=1000.0, damping=5.0))
    else:
        cube.add(cressim.SoftBody(mesh, radius=r, mass=0.01, distance_compliance=0.01, volume_compliance=0.0,
                                  damping=1.0))


def kinematic_plate(world):
    plate = world.create_entity(env=0, name="plate")
    plate.add(cressim.Transform(position=(0, 0, -0.05)))
    plate.add(cressim.RigidBody(kinematic=True))
    plate.add(cressim.Collider(cressim.Shape.box((0.3, 0.3, 0.05))))


def lid(world, height=0.3):
    box = world.create_entity(env=0, name="lid")
    box.add(cressim.Transform(position=(0, 0, height)))
    box.add(cressim.RigidBody(mass=0.2))
    box.add(cressim.Collider(cressim.Shape.box((0.06, 0.06, 0.06))))


def settled_forces(engine):
    """Contact forces per body, averaged over the last half second of 2 s."""
    step(engine, 90)
    return step(engine, 30, lambda e: e.buffer("rigid.contact_forces").read()[:, :3].copy()).mean(axis=0)


@pytest.mark.parametrize("elastic", [False, True])
def test_kinematic_plate_under_a_soft_cube_reads_its_weight(make_engine, elastic):
    world = cressim.World(cressim.SceneLayout(1))
    kinematic_plate(world)
    soft_cube(world, elastic=elastic)
    engine = start(world, make_engine, substeps=4, particle_iterations=8)
    forces = settled_forces(engine)
    weight = (8.0 if elastic else 0.01 * 125) * G
    np.testing.assert_allclose(forces[0], [0, 0, -weight], atol=0.03 * weight)


def test_box_lying_on_a_soft_cube_reads_its_weight(make_engine):
    world = cressim.World(cressim.SceneLayout(1))
    static(world, 0, [cressim.Shape.plane()], "ground")
    soft_cube(world)
    lid(world)
    engine = start(world, make_engine, substeps=4, particle_iterations=8)
    forces = settled_forces(engine)
    np.testing.assert_allclose(forces[0], [0, 0, 0.2 * G], atol=0.03 * 0.2 * G)
    per_particle = engine.buffer("particles.rigid_forces").read()
    on_lid = per_particle[:, 3] == 1  # w: body index + 1
    assert on_lid.any() and abs(per_particle[on_lid, 2].sum() - 0.2 * G) < 0.03 * 0.2 * G  # last frame


def test_plate_under_a_soft_cube_and_a_box_reads_both_weights(make_engine):
    """The box's weight reaches the plate through the particles once, not once per substep (a
    dynamic body takes its particle pushes over the substep, as the particles do)."""
    world = cressim.World(cressim.SceneLayout(1))
    kinematic_plate(world)
    soft_cube(world)
    lid(world)
    engine = start(world, make_engine, substeps=4, particle_iterations=8)
    forces = settled_forces(engine)
    weight = (0.01 * 125 + 0.2) * G
    np.testing.assert_allclose(forces[0], [0, 0, -weight], atol=0.03 * weight)
    np.testing.assert_allclose(forces[1], [0, 0, 0.2 * G], atol=0.05 * 0.2 * G)
