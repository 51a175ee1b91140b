"""Physical randomization changes what it should in its own env only, checked against closed
forms: a body pushed by a drive capped at F accelerates at F/m with its drawn mass; a box on a
slope steeper than its friction angle slides at g (sin - mu cos) with its drawn mu; a velocity
drive's drawn damping c gives the first-order lag v = u (1 - exp(-c t)); a position drive's drawn
stiffness k swings a 1 kg block with the period 2 pi / sqrt(k); a ball's drawn restitution e
bounces it to e^2 of its drop."""
import math

import numpy as np

import cressim
from cressim.randomization import Randomizer

from .frames import randomized_frame, steps

DT = 1 / 60
G = 9.81


def pushed_blocks(make_engine, envs, force):
    """A 1 kg block per env on a slider whose velocity drive (target 100 m/s) is capped at `force`."""
    world = cressim.World(cressim.SceneLayout(envs))
    for env in range(envs):
        b = world.create_entity(env=env, name="block")
        b.add(cressim.Transform())
        b.add(cressim.RigidBody(mass=1.0))
        b.add(cressim.Collider(cressim.Shape.box((0.1, 0.1, 0.1)), group=0, mask=0))
        world.create_entity(env=env, name="slide").add(cressim.Joint(
            "slider", body_b=b, axis=(1, 0, 0), drive="velocity", damping=1e6, max_force=force, target=100.0))
    engine = make_engine(world)
    engine.physics = cressim.PhysicsSettings(dt=DT, substeps=4, iterations=1, gravity=(0, 0, 0), max_contacts_per_env=0)
    engine.prepare()
    engine.upload_world()
    return engine


def test_mass_sets_each_envs_acceleration_to_force_over_mass(make_engine):
    force, frames = 2.0, 30
    engine = pushed_blocks(make_engine, 4, force)
    r = Randomizer(engine, [dict(param="mass", entity="block", range=[0.5, 4.0], operation="abs")], seed=3)
    randomized_frame(engine, r, reset_all=True, physics=False)
    mass = r.read("mass/block")[:, 0]
    assert len(set(mass.round(4))) == 4 and ((0.5 <= mass) & (mass <= 4.0)).all()
    v = steps(engine, frames, lambda e: e.buffer("rigid.linear_velocities").read()[:, 0].copy())
    # v = F t / m in every env, with that env's mass
    np.testing.assert_allclose(v[-1], force * frames * DT / mass, rtol=1e-4)
    # the inertia scaled with the mass (inverse inertia x m0 / m)
    inv = engine.buffer("rigid.bodies").read().view(np.float32).reshape(4, -1)[:, :4]
    np.testing.assert_allclose(inv[:, 3], 1 / mass, rtol=1e-6)
    np.testing.assert_allclose(inv[:, 0] * mass, inv[0, 0] * mass[0], rtol=1e-5)


def test_mass_scale_acts_on_the_authored_mass_and_never_compounds(make_engine):
    engine = pushed_blocks(make_engine, 2, 1.0)
    r = Randomizer(engine, [dict(param="mass", entity="block", range=[2.0, 2.0], operation="scale")])
    for _ in range(3):  # drawn three times: 2 x the authored 1 kg, not 8
        randomized_frame(engine, r, reset_all=True, physics=False)
    inv = engine.buffer("rigid.bodies").read().view(np.float32).reshape(2, -1)
    np.testing.assert_allclose(inv[:, 3], 0.5)


def test_friction_sets_each_envs_sliding_acceleration_by_coulombs_law(make_engine):
    envs, angle = 3, math.atan(0.8)  # steeper than every drawn friction angle
    q = (0, math.sin(-angle / 2), 0, math.cos(-angle / 2))
    normal = np.array([-math.sin(angle), 0, math.cos(angle)])
    downhill = np.array([-math.cos(angle), 0, -math.sin(angle)])
    world = cressim.World(cressim.SceneLayout(envs))
    for env in range(envs):
        slope = world.create_entity(env=env, name="slope")
        slope.add(cressim.Transform(rotation=q))
        slope.add(cressim.Collider(cressim.Shape.plane(), static_friction=0.5))
        box = world.create_entity(env=env, name="box")
        box.add(cressim.Transform(position=tuple(normal * 0.1), rotation=q))
        box.add(cressim.RigidBody(mass=1))
        box.add(cressim.Collider(cressim.Shape.box((0.1, 0.1, 0.1)), static_friction=0.5))
    engine = make_engine(world)
    engine.prepare()
    engine.upload_world()
    # one draw per env, written to both colliders of the env (the contact uses their pair)
    r = Randomizer(engine, [dict(param="friction", entity="*", range=[0.1, 0.6], operation="abs")], seed=11)
    randomized_frame(engine, r, reset_all=True, physics=False)
    mu = r.read("friction/*")[:, 0]
    assert np.ptp(mu) > 0.1
    material = engine.buffer("rigid.colliders").read().view(np.float32).reshape(2 * envs, -1)[:, 12:14]
    np.testing.assert_allclose(material, np.repeat(mu, 2)[:, None].repeat(2, 1), rtol=1e-6)
    x = steps(engine, 120, lambda e: e.buffer("rigid.positions").read()[:, :3].copy())
    s = (x - x[0]) @ downhill
    t = np.arange(1, len(s) + 1) * DT
    for env in range(envs):
        acceleration = 2 * np.polyfit(t, s[:, env], 2)[0]
        expected = G * (math.sin(angle) - mu[env] * math.cos(angle))
        assert abs(acceleration / expected - 1) < 0.05, (env, mu[env], acceleration, expected)


def test_joint_damping_sets_the_speed_a_capped_drive_reaches(make_engine):
    # the drive's force c (u - v) on 1 kg, with the drawn damping c: v(t) = u (1 - exp(-c t))
    world = cressim.World(cressim.SceneLayout(2))
    for env in range(2):
        b = world.create_entity(env=env, name="block")
        b.add(cressim.Transform())
        b.add(cressim.RigidBody(mass=1.0))
        b.add(cressim.Collider(cressim.Shape.box((0.1, 0.1, 0.1)), group=0, mask=0))
        world.create_entity(env=env, name="slide").add(cressim.Joint(
            "slider", body_b=b, axis=(1, 0, 0), drive="velocity", damping=1.0, target=1.0))
    engine = make_engine(world)
    engine.physics = cressim.PhysicsSettings(dt=DT, substeps=4, iterations=1, gravity=(0, 0, 0), max_contacts_per_env=0)
    engine.prepare()
    engine.upload_world()
    r = Randomizer(engine, [dict(param="joint_damping", entity="slide", range=[0.5, 3.0], operation="abs")], seed=5)
    randomized_frame(engine, r, reset_all=True, physics=False)
    c = r.read("joint_damping/slide")[:, 0]
    drive = engine.buffer("joint.model").read().view(np.float32).reshape(2, -1)[:, 20:24]
    np.testing.assert_allclose(drive[:, 1], c, rtol=1e-6)
    v = steps(engine, 30, lambda e: e.buffer("rigid.linear_velocities").read()[:, 0].copy())
    np.testing.assert_allclose(v[-1], 1 - np.exp(-c * 30 * DT), rtol=0.03)


def test_joint_stiffness_sets_the_period_of_a_position_drive(make_engine):
    # a 1 kg block on an undamped position drive (a spring k to 0.1 m back), let go: x = 0.1 cos(sqrt(k) t)
    envs = 3
    world = cressim.World(cressim.SceneLayout(envs))
    for env in range(envs):
        b = world.create_entity(env=env, name="block")
        b.add(cressim.Transform(position=(0.1, 0, 0)))
        b.add(cressim.RigidBody(mass=1.0))
        b.add(cressim.Collider(cressim.Shape.box((0.05, 0.05, 0.05)), group=0, mask=0))
        world.create_entity(env=env, name="spring").add(cressim.Joint(
            "slider", body_b=b, axis=(1, 0, 0), drive="position", target=-0.1, stiffness=100.0))
    engine = make_engine(world)
    engine.physics = cressim.PhysicsSettings(dt=DT, substeps=8, iterations=1, gravity=(0, 0, 0), max_contacts_per_env=0)
    engine.prepare()
    engine.upload_world()
    r = Randomizer(engine, [dict(param="joint_stiffness", entity="spring", range=[40.0, 160.0], operation="abs")],
                   seed=2)
    randomized_frame(engine, r, reset_all=True, physics=False)
    k = r.read("joint_stiffness/spring")[:, 0]
    x = steps(engine, 150, lambda e: e.buffer("rigid.positions").read()[:, 0].copy())
    t = np.arange(1, len(x) + 1) * DT
    for env in range(envs):
        s = x[:, env]
        crossings = [t[i] - s[i] * DT / (s[i + 1] - s[i]) for i in range(len(s) - 1) if s[i] > 0 >= s[i + 1]]
        period = np.diff(crossings).mean()
        assert abs(period / (2 * math.pi / math.sqrt(k[env])) - 1) < 0.02, (env, k[env], period)


def test_restitution_sets_each_envs_bounce_height(make_engine):
    # a ball dropped from 1 m on a plane bounces to e^2 m (the contact takes the larger restitution)
    envs = 3
    world = cressim.World(cressim.SceneLayout(envs))
    for env in range(envs):
        ground = world.create_entity(env=env, name="ground")
        ground.add(cressim.Transform())
        ground.add(cressim.Collider(cressim.Shape.plane()))
        ball = world.create_entity(env=env, name="ball")
        ball.add(cressim.Transform(position=(0, 0, 1.05)))
        ball.add(cressim.RigidBody(mass=1))
        ball.add(cressim.Collider(cressim.Shape.sphere(0.05), restitution=0.5))
    engine = make_engine(world)
    engine.physics = cressim.PhysicsSettings(substeps=16)
    engine.prepare()
    engine.upload_world()
    r = Randomizer(engine, [dict(param="restitution", entity="ball", range=[0.3, 0.8], operation="abs")], seed=8)
    randomized_frame(engine, r, reset_all=True, physics=False)
    e = r.read("restitution/ball")[:, 0]
    z = steps(engine, 120, lambda en: en.buffer("rigid.positions").read()[:, 2].copy()) - 0.05
    for env in range(envs):
        first_bounce = np.argmin(z[:40, env])
        peak = z[first_bounce:first_bounce + 60, env].max()
        assert abs(peak - e[env] ** 2) < 0.03, (env, e[env], peak)
    assert np.ptp(e) > 0.1
