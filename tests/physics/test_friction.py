"""Coulomb friction for every shape and contact count: on a slope at 0.8 and 1.25 times the
friction angle a body sticks (< 1 mm in 5 s) or slides at g (sin - mu cos) within 5 %; a box
pinched between two jaws is held when the friction of both faces, 2 mu N, exceeds m g and
slides down at g - 2 mu N / m when it does not. The engine has no triangle-mesh collider: the
mesh case is a proxy-particle collider (spheres at a hexagonal prism's vertices)."""
import math

import numpy as np
import pytest

import cressim

from .scenes import start, step

G = 9.81
MU = 0.5
DT = 1 / 60


def shape(kind):
    """(shape, distance from the body origin to the ground)"""
    if kind == "box":
        return cressim.Shape.box((0.1, 0.1, 0.1)), 0.1
    if kind == "capsule":  # lying along the slope, so it slides rather than rolls
        s = math.sqrt(0.5)
        return cressim.Shape.capsule(0.05, 0.15, rotation=(0, s, 0, s)), 0.05
    points = [(0.12 * math.cos(a), 0.12 * math.sin(a), z) for a in np.arange(6) * math.pi / 3 for z in (-0.05, 0.05)]
    return cressim.Shape.proxy_particles(points, 0.03), 0.08


def slide_along_slope(make_engine, kind, angle, seconds=5.0):
    """Distance (m) a body slid down a plane tilted by `angle`, per frame."""
    q = (0, math.sin(-angle / 2), 0, math.cos(-angle / 2))  # turned about y: downhill is -x
    normal = np.array([-math.sin(angle), 0, math.cos(angle)])
    downhill = np.array([-math.cos(angle), 0, -math.sin(angle)])
    world = cressim.World(cressim.SceneLayout(1))
    ground = world.create_entity(env=0, name="slope")
    ground.add(cressim.Transform(rotation=q))
    ground.add(cressim.Collider(cressim.Shape.plane(), static_friction=MU))
    s, reach = shape(kind)
    body = world.create_entity(env=0, name=kind)
    body.add(cressim.Transform(position=tuple(normal * reach), rotation=q))
    body.add(cressim.RigidBody(mass=1))
    body.add(cressim.Collider(s, static_friction=MU))
    engine = start(world, make_engine)
    x = step(engine, round(seconds / DT), lambda e: e.buffer("rigid.positions").read()[0, :3].copy())
    return (x - x[0]) @ downhill


@pytest.mark.parametrize("kind", ["box", "capsule", "mesh"])
def test_sticks_below_the_friction_angle(make_engine, kind):
    s = slide_along_slope(make_engine, kind, 0.8 * math.atan(MU))
    assert np.abs(s).max() < 1e-3


@pytest.mark.parametrize("kind", ["box", "capsule", "mesh"])
def test_slides_above_the_friction_angle_at_coulomb_acceleration(make_engine, kind):
    angle = 1.25 * math.atan(MU)
    s = slide_along_slope(make_engine, kind, angle)
    t = np.arange(1, len(s) + 1) * DT
    acceleration = 2 * np.polyfit(t, s, 2)[0]
    expected = G * (math.sin(angle) - MU * math.cos(angle))
    assert abs(acceleration / expected - 1) < 0.05


def pinch(make_engine, squeeze):
    """A 1 kg box between a kinematic jaw and a jaw pressed by a slider drive capped at
    `squeeze` N (its target lies inside the box, so the cap is the force); returns the box's height
    per frame over 2 s."""
    world = cressim.World(cressim.SceneLayout(1))
    fixed = world.create_entity(env=0, name="fixed_jaw")
    fixed.add(cressim.Transform(position=(-0.1, 0, 0)))
    fixed.add(cressim.RigidBody(kinematic=True))
    fixed.add(cressim.Collider(cressim.Shape.box((0.05, 0.1, 0.1)), static_friction=MU))
    box = world.create_entity(env=0, name="box")
    box.add(cressim.Transform())
    box.add(cressim.RigidBody(mass=1))
    box.add(cressim.Collider(cressim.Shape.box((0.05, 0.05, 0.05)), static_friction=MU))
    jaw = world.create_entity(env=0, name="pressing_jaw")
    jaw.add(cressim.Transform(position=(0.1, 0, 0)))
    jaw.add(cressim.RigidBody(mass=0.5))
    jaw.add(cressim.Collider(cressim.Shape.box((0.05, 0.1, 0.1)), static_friction=MU))
    world.create_entity(env=0).add(cressim.Joint(
        "slider", body_b=jaw, anchor=(0.1, 0, 0), axis=(1, 0, 0), drive="position", target=-0.05, stiffness=1e6,
        max_force=squeeze))
    engine = start(world, make_engine, substeps=8)
    return step(engine, 120, lambda e: e.buffer("rigid.positions").read()[1, 2])


def test_pinched_box_is_held_when_friction_exceeds_its_weight(make_engine):
    z = pinch(make_engine, squeeze=1.5 * G / (2 * MU))  # 2 mu N = 1.5 m g
    assert np.abs(z).max() < 1e-3


def test_pinched_box_slips_when_its_weight_exceeds_friction(make_engine):
    squeeze = 0.6 * G / (2 * MU)  # 2 mu N = 0.6 m g
    z = pinch(make_engine, squeeze)
    t = np.arange(1, len(z) + 1) * DT
    between = z > -0.1  # still between the jaws (their lower edges are at -0.1)
    acceleration = -2 * np.polyfit(t[between], z[between], 2)[0]
    assert abs(acceleration / (G - 2 * MU * squeeze) - 1) < 0.05
