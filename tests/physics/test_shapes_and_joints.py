"""Every collider shape and joint kind against a simple reference."""
import math

import numpy as np

import cressim

from .scenes import body, ground, set_reset, start, step


def test_capsule_and_proxy_particles_rest_at_their_radius(make_engine):
    world = cressim.World(cressim.SceneLayout(1))
    ground(world, 0)
    capsule = world.create_entity(env=0, name="capsule")
    # lying along x: the shape turned a quarter about y
    capsule.add(cressim.Transform(position=(0, 0, 0.2)))
    capsule.add(cressim.RigidBody(mass=1))
    s = math.sqrt(0.5)
    capsule.add(cressim.Collider(cressim.Shape.capsule(0.05, 0.2, rotation=(0, s, 0, s))))
    proxy = world.create_entity(env=0, name="proxy")
    proxy.add(cressim.Transform(position=(1, 0, 0.2)))
    proxy.add(cressim.RigidBody(mass=1))
    corners = [(x, y, 0) for x in (-0.1, 0.1) for y in (-0.1, 0.1)]
    proxy.add(cressim.Collider(cressim.Shape.proxy_particles(corners, 0.03)))
    engine = start(world, make_engine, substeps=8)
    step(engine, 120)
    pos = engine.buffer("rigid.positions").read()
    assert abs(pos[0, 2] - 0.05) < 1e-3 and abs(pos[1, 2] - 0.03) < 1e-3


def test_head_on_elastic_spheres_exchange_velocities(make_engine):
    world = cressim.World(cressim.SceneLayout(1), )
    for k, x in enumerate((-0.5, 0.5)):
        b = world.create_entity(env=0, name=f"ball{k}")
        b.add(cressim.Transform(position=(x, 0, 0)))
        b.add(cressim.RigidBody(mass=1))
        b.add(cressim.Collider(cressim.Shape.sphere(0.1), restitution=1.0, static_friction=0))
    engine = start(world, make_engine, substeps=8, gravity=(0, 0, 0))
    set_reset(engine, "control.body_reset_velocities", 0, [2.0, 0, 0])
    v = step(engine, 60, lambda e: e.buffer("rigid.linear_velocities").read()[:, 0].copy())
    np.testing.assert_allclose(v[-1], [0, 2.0], atol=0.05)  # momentum 2, energy kept
    np.testing.assert_allclose(v.sum(axis=1), 2.0, atol=1e-3)  # momentum at every frame


def test_ball_joint_holds_its_anchor_and_fixed_joint_holds_the_pose(make_engine):
    world = cressim.World(cressim.SceneLayout(1))
    bob = world.create_entity(env=0, name="bob")
    bob.add(cressim.Transform(position=(0.5, 0, 0)))
    bob.add(cressim.RigidBody(mass=1))
    bob.add(cressim.Collider(cressim.Shape.box((0.5, 0.02, 0.02)), mask=0))
    world.create_entity(env=0).add(cressim.Joint("ball", body_b=bob, anchor=(0, 0, 0)))
    tip = world.create_entity(env=0, name="tip")
    tip.add(cressim.Transform(position=(1.1, 0, 0)))
    tip.add(cressim.RigidBody(mass=0.2))
    tip.add(cressim.Collider(cressim.Shape.sphere(0.1), mask=0))
    world.create_entity(env=0).add(cressim.Joint("fixed", body_a=bob, body_b=tip, anchor=(1.0, 0, 0)))
    engine = start(world, make_engine, substeps=8)
    step(engine, 90)
    pos, rot = engine.buffer("rigid.positions").read(), engine.buffer("rigid.rotations").read()
    # the bob's end at the anchor stays at the origin; the tip stays 0.6 from the bob's centre
    end = pos[0, :3] - _rotate(rot[0], np.array([0.5, 0, 0]))
    assert np.linalg.norm(end) < 2e-3
    assert abs(np.linalg.norm(pos[1, :3] - pos[0, :3]) - 0.6) < 2e-3
    assert abs(np.dot(rot[0], rot[1])) > math.cos(math.radians(0.5) / 2)  # same orientation
    assert pos[0, 2] < -0.3  # it did swing down


def test_spherical_drive_reaches_its_target_rotation(make_engine):
    world = cressim.World(cressim.SceneLayout(1))
    b = world.create_entity(env=0, name="wrist")
    b.add(cressim.Transform())
    b.add(cressim.RigidBody(mass=1, inertia=(0.01, 0.01, 0.01)))
    target = (0, 0, math.sin(0.3), math.cos(0.3))  # 0.6 rad about z
    world.create_entity(env=0).add(cressim.Joint(
        "spherical", body_b=b, drive="position", target_rotation=target, stiffness=50, damping=2))
    engine = start(world, make_engine, substeps=8, gravity=(0, 0, 0))
    step(engine, 240)
    q = body(engine, "rigid.rotations")
    assert abs(np.dot(q, target)) > math.cos(math.radians(1) / 2)  # within 1 deg


def _rotate(q, v):
    x, y, z, w = q
    u = np.array([x, y, z])
    t = 2 * np.cross(u, v)
    return v + w * t + np.cross(u, t)
