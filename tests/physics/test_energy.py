"""What the solver does to energy: a hinged rod swinging from 0.5 rad loses energy at a steady
rate (the position projection is first order in the substep). docs/physics.md reports these
numbers: about 10 % per period at the defaults (4 substeps at 60 Hz), halving with each doubling
of the substeps; iterations do not change it."""
import math

import numpy as np
import pytest

import cressim

from .scenes import set_reset, start, step

G = 9.81
DT = 1 / 60
LENGTH, WIDTH = 1.0, 0.02
INERTIA = (WIDTH**2 + LENGTH**2) / 12  # 1 kg rod about its centre


def energy_loss_per_period(make_engine, **settings):
    world = cressim.World(cressim.SceneLayout(1))
    rod = world.create_entity(env=0, name="rod")
    rod.add(cressim.Transform(position=(0, 0, -LENGTH / 2)))
    rod.add(cressim.RigidBody(mass=1.0))
    rod.add(cressim.Collider(cressim.Shape.box((WIDTH / 2, WIDTH / 2, LENGTH / 2)), mask=0))
    world.create_entity(env=0, name="pivot").add(
        cressim.Joint("hinge", body_b=rod, anchor=(0, 0, 0), axis=(0, 1, 0)))
    engine = start(world, make_engine, **settings)
    set_reset(engine, "control.joint_reset", 0, [0.5])

    def energy(e):
        z = e.buffer("rigid.positions").read()[0, 2]
        v = e.buffer("rigid.linear_velocities").read()[0, :3]
        w = e.buffer("rigid.angular_velocities").read()[0, :3]
        return G * (z + LENGTH / 2) + 0.5 * v @ v + 0.5 * INERTIA * w @ w

    e = step(engine, 600, energy)  # 10 s, about 6 periods
    period = 2 * math.pi * math.sqrt((INERTIA + (LENGTH / 2) ** 2) / (G * LENGTH / 2))
    rate = np.polyfit(np.arange(1, len(e) + 1) * DT, np.log(e), 1)[0]  # e ~ exp(rate t)
    return 1 - math.exp(rate * period)


def test_pendulum_loses_about_a_tenth_of_its_energy_per_period_at_the_defaults(make_engine):
    assert 0.08 < energy_loss_per_period(make_engine) < 0.12


@pytest.mark.parametrize("substeps", [8, 16])
def test_pendulum_energy_loss_halves_with_each_doubling_of_substeps(make_engine, substeps):
    loss = energy_loss_per_period(make_engine, substeps=substeps)
    assert abs(loss / (0.10 * 4 / substeps) - 1) < 0.2
