"""Rigid bodies checked against references: analytic motion, a pendulum's period, Coulomb
friction, and what must not happen (sinking, drift, leaking between envs). Tolerances are
stated at each assertion."""
import math

import numpy as np
import pytest

import cressim

from .scenes import body, box, ground, set_reset, start, step

G = 9.81
DT = 1 / 60


def test_free_fall_matches_the_analytic_solution(make_engine):
    world = cressim.World(cressim.SceneLayout(1))
    ball = world.create_entity(env=0, name="ball")
    ball.add(cressim.Transform(position=(0, 0, 1)))
    ball.add(cressim.RigidBody(mass=1))
    ball.add(cressim.Collider(cressim.Shape.sphere(0.05)))
    engine = start(world, make_engine, substeps=4)
    z = step(engine, 30, lambda e: body(e, "rigid.positions")[2])
    t = np.arange(1, 31) * DT
    h = DT / 4
    # the integrator is semi-implicit Euler: exact for its own recurrence, within g*h*t/2 of the parabola
    discrete = 1 - G * h * h * (4 * np.arange(1, 31)) * (4 * np.arange(1, 31) + 1) / 2
    np.testing.assert_allclose(z, discrete, atol=2e-4)  # float32 position rounding
    assert np.all(np.abs(z - (1 - G * t * t / 2)) <= G * h * t / 2 + 2e-4)


def test_a_kinematic_body_made_dynamic_falls_and_made_kinematic_again_holds(make_engine):
    """control.body_kinematic, taken at each frame's start: a kinematic ball with a mass held at its
    target falls freely once made dynamic (semi-implicit Euler's recurrence from rest) and, made
    kinematic again, goes to its target and stays; a kinematic body without a mass stays put."""
    world = cressim.World(cressim.SceneLayout(1))
    ball = world.create_entity(env=0, name="ball")
    ball.add(cressim.Transform(position=(0, 0, 1)))
    ball.add(cressim.RigidBody(mass=1, kinematic=True))
    ball.add(cressim.Collider(cressim.Shape.sphere(0.05)))
    massless = world.create_entity(env=0, name="massless")
    massless.add(cressim.Transform(position=(1, 0, 1)))
    massless.add(cressim.RigidBody(kinematic=True, inertia=(1, 1, 1)))
    engine = start(world, make_engine, substeps=4)
    step(engine, 10)
    assert body(engine, "rigid.positions")[2] == pytest.approx(1.0, abs=1e-6)  # held at its target
    engine.buffer("control.body_kinematic").write(np.array([0, 0], np.uint32))
    z = step(engine, 20, lambda e: body(e, "rigid.positions")[2])
    n = 4 * np.arange(1, 21)
    np.testing.assert_allclose(z, 1 - G * (DT / 4) ** 2 * n * (n + 1) / 2, atol=2e-4)
    assert body(engine, "rigid.positions", 1)[2] == pytest.approx(1.0, abs=1e-6)  # no mass: still kinematic
    engine.buffer("control.body_kinematic").write(np.array([1, 1], np.uint32))
    z = step(engine, 10, lambda e: body(e, "rigid.positions")[2])
    assert z[0] == pytest.approx(1.0, abs=1e-5) and z[-1] == pytest.approx(1.0, abs=1e-6)  # back to its target


@pytest.mark.parametrize("substeps", [4, 8])
def test_hinge_pendulum_period_within_one_percent(make_engine, substeps):
    world = cressim.World(cressim.SceneLayout(1))
    length, mass = 1.0, 1.0
    rod = world.create_entity(env=0, name="rod")
    rod.add(cressim.Transform(position=(0, 0, -length / 2)))
    rod.add(cressim.RigidBody(mass=mass))
    rod.add(cressim.Collider(cressim.Shape.box((0.01, 0.01, length / 2)), mask=0))
    world.create_entity(env=0, name="pivot").add(
        cressim.Joint("hinge", body_b=rod, anchor=(0, 0, 0), axis=(0, 1, 0)))
    engine = start(world, make_engine, substeps=substeps)
    set_reset(engine, "control.joint_reset", 0, [0.05])  # 0.05 rad: small-angle regime
    angle = step(engine, 600, lambda e: e.buffer("joint.positions").read()[0])
    t = np.arange(1, 601) * DT
    i = np.where((angle[:-1] < 0) & (angle[1:] >= 0))[0]
    crossings = t[i] + DT * -angle[i] / (angle[i + 1] - angle[i])
    inertia = mass * (0.02**2 + length**2) / 12 + mass * (length / 2) ** 2  # about the pivot
    expected = 2 * math.pi * math.sqrt(inertia / (mass * G * length / 2))
    assert len(crossings) >= 5
    assert abs(np.diff(crossings).mean() / expected - 1) < 0.01


def test_box_rests_on_a_plane_without_sinking_or_drifting(make_engine):
    world = cressim.World(cressim.SceneLayout(1))
    ground(world, 0)
    box(world, 0, (0, 0, 0.1))
    engine = start(world, make_engine)
    pos = step(engine, 600, lambda e: body(e, "rigid.positions")[:3])  # 10 s
    assert np.all(pos[:, 2] > 0.1 - 1e-3)  # penetration < 1 mm throughout
    assert np.linalg.norm(pos[-1, :2]) < 1e-3  # no drift beyond 1 mm
    q = body(engine, "rigid.rotations")
    assert abs(q[3]) > math.cos(math.radians(0.5) / 2)  # turned less than 0.5 deg


def test_sliding_box_decelerates_at_mu_g(make_engine):
    mu = 0.4
    world = cressim.World(cressim.SceneLayout(1))
    ground(world, 0, friction=mu)
    box(world, 0, (0, 0, 0.1), friction=mu)
    engine = start(world, make_engine, substeps=8)
    step(engine, 6)  # settle onto the plane
    set_reset(engine, "control.body_reset_velocities", 0, [3.0, 0, 0])
    v = step(engine, 40, lambda e: body(e, "rigid.linear_velocities")[0])
    t = np.arange(1, 41) * DT
    moving = v > 0.2
    slope = np.polyfit(t[moving], v[moving], 1)[0]
    assert abs(-slope / (mu * G) - 1) < 0.05


def test_restitution_bounce_height(make_engine):
    e_restitution = 0.5
    world = cressim.World(cressim.SceneLayout(1))
    ground(world, 0)
    ball = world.create_entity(env=0, name="ball")
    ball.add(cressim.Transform(position=(0, 0, 1.05)))
    ball.add(cressim.RigidBody(mass=1))
    ball.add(cressim.Collider(cressim.Shape.sphere(0.05), restitution=e_restitution))
    engine = start(world, make_engine, substeps=16)
    z = step(engine, 120, lambda e: body(e, "rigid.positions")[2]) - 0.05
    first_bounce = np.argmin(z[:40])
    peak = z[first_bounce:first_bounce + 60].max()
    assert abs(peak / 1.0 - e_restitution**2) < 0.03  # h1 / h0 = e^2


def test_slider_velocity_drive_tracks_its_target(make_engine):
    world = cressim.World(cressim.SceneLayout(1))
    cart = world.create_entity(env=0, name="cart")
    cart.add(cressim.Transform())
    cart.add(cressim.RigidBody(mass=1, inertia=(0.1, 0.1, 0.1)))
    world.create_entity(env=0, name="rail").add(cressim.Joint(
        "slider", body_b=cart, axis=(1, 0, 0), drive="velocity", target=0.5, damping=1e4, max_force=1e3))
    engine = start(world, make_engine)
    qd = step(engine, 60, lambda e: e.buffer("joint.velocities").read()[0])
    assert abs(qd[-1] - 0.5) < 0.005  # within 1 %
    q = engine.buffer("joint.positions").read()[0]
    assert abs(q - 0.5) < 0.02  # 1 s at 0.5 m/s
    assert np.linalg.norm(body(engine, "rigid.positions")[1:3]) < 1e-4  # stays on the rail


def test_slider_position_drive_settles_on_its_target(make_engine):
    world = cressim.World(cressim.SceneLayout(1))
    cart = world.create_entity(env=0, name="cart")
    cart.add(cressim.Transform())
    cart.add(cressim.RigidBody(mass=1, inertia=(0.1, 0.1, 0.1)))
    world.create_entity(env=0).add(cressim.Joint(
        "slider", body_b=cart, axis=(0, 1, 0), drive="position", target=0.3, stiffness=400, damping=40))
    engine = start(world, make_engine)
    step(engine, 180)
    assert abs(engine.buffer("joint.positions").read()[0] - 0.3) < 1e-3


def test_hinge_limits_hold(make_engine):
    world = cressim.World(cressim.SceneLayout(1))
    rod = world.create_entity(env=0, name="rod")
    rod.add(cressim.Transform(position=(0, 0, -0.5)))
    rod.add(cressim.RigidBody(mass=1))
    rod.add(cressim.Collider(cressim.Shape.box((0.02, 0.02, 0.5)), mask=0))
    world.create_entity(env=0).add(cressim.Joint(
        "hinge", body_b=rod, anchor=(0, 0, 0), axis=(0, 1, 0), limits=(-0.3, 0.3)))
    engine = start(world, make_engine, substeps=8)
    set_reset(engine, "control.joint_reset", 0, [0.3, 4.0])  # at the limit, swinging out fast
    angle = step(engine, 240, lambda e: e.buffer("joint.positions").read()[0])
    assert np.abs(angle).max() < 0.3 + 0.01  # 0.01 rad: one substep of overshoot at most
    assert angle.min() < -0.2  # it does swing across


def test_stack_of_five_boxes_stays_standing(make_engine):
    world = cressim.World(cressim.SceneLayout(1))
    ground(world, 0)
    for k in range(5):
        box(world, 0, (0, 0, 0.1 + 0.2 * k + 0.001 * k), name=f"box{k}")
    engine = start(world, make_engine, substeps=8)
    step(engine, 300)  # 5 s
    pos = engine.buffer("rigid.positions").read()[:, :3]
    assert np.all(np.linalg.norm(pos[:, :2], axis=1) < 0.01)  # no box slid more than 1 cm
    np.testing.assert_allclose(pos[:, 2], 0.1 + 0.2 * np.arange(5), atol=5e-3)  # 5 mm


def test_bodies_drive_their_entity_transforms(make_engine):
    world = cressim.World(cressim.SceneLayout(1))
    ground(world, 0)
    b = box(world, 0, (0, 0, 0.5))
    engine = start(world, make_engine)
    step(engine, 10)
    row = engine.mapping["entity_row"][b.id]
    np.testing.assert_array_equal(engine.buffer("transform.positions").read()[row, :3], body(engine, "rigid.positions")[:3])


def _env0_trajectory(make_engine, with_second_env):
    world = cressim.World(cressim.SceneLayout(2 if with_second_env else 1))
    ground(world, 0)
    box(world, 0, (0, 0, 0.3))
    b = box(world, 0, (0.05, 0, 0.6), name="top")
    if with_second_env:  # different content in env 1, authored in between
        ground(world, 1, friction=0.9)
        for k in range(3):
            box(world, 1, (0.02 * k, 0, 0.15 + 0.25 * k), half=0.12, mass=2.0)
    engine = start(world, make_engine)
    return step(engine, 120, lambda e: e.buffer("rigid.positions").read()[: 2].copy()), b


def test_envs_never_affect_each_other(make_engine):
    alone, _ = _env0_trajectory(make_engine, False)
    beside, _ = _env0_trajectory(make_engine, True)
    assert np.array_equal(alone, beside)  # bit for bit


def test_an_exploding_env_is_flagged_and_reset_alone(make_engine):
    world = cressim.World(cressim.SceneLayout(2))
    for env in range(2):
        ground(world, env)
        box(world, env, (0, 0, 0.3))
    engine = start(world, make_engine)
    set_reset(engine, "control.body_reset_velocities", 1, [1e4, 0, 0], env=1)  # env 1 explodes
    step(engine, 1)
    assert list(engine.buffer("env.health").read()) == [0, 2]  # HEALTH_SPEED in env 1 only
    assert list(engine.buffer("env.reset_mask").read()) == [0, 1]  # reset requested
    assert engine.health_events == 1  # and reported (the engine logs a warning)
    resets_before = engine.buffer("env.reset_count").read().copy()
    engine.buffer("control.body_reset_velocities").write(np.zeros((2, 4)))
    step(engine, 1)
    assert list(engine.buffer("env.reset_count").read() - resets_before) == [0, 1]
    assert list(engine.buffer("env.health").read()) == [0, 0]
    assert engine.health_events == 1
    pos = engine.buffer("rigid.positions").read()
    assert np.all(np.isfinite(pos)) and abs(pos[1, 0]) < 0.01


def test_authoring_errors_name_the_entity(make_engine):
    world = cressim.World(cressim.SceneLayout(2))
    a = box(world, 0, (0, 0, 1), name="a")
    b = box(world, 1, (0, 0, 1), name="b")
    world.create_entity(env=0, name="bad_joint").add(cressim.Joint("hinge", body_a=a, body_b=b))
    engine = make_engine(world)
    with pytest.raises(ValueError, match=r"entity 2 'bad_joint' in env 0: Joint.body_b is entity 1 'b' in env 1"):
        engine.prepare()
    world2 = cressim.World(cressim.SceneLayout(1))
    e = world2.create_entity(env=0, name="floating")
    e.add(cressim.RigidBody(mass=1))
    with pytest.raises(ValueError, match="'floating' in env 0: RigidBody.inertia is not given"):
        make_engine(world2).prepare()
    with pytest.raises(ValueError, match="Joint kind 'hing' is not one of"):
        cressim.Joint("hing")
