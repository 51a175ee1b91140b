"""Small particle scenes for the particle tests (z up, SI units)."""
import math

import numpy as np

import cressim

from .scenes import start  # noqa: F401  (the particle tests start engines the same way)


def lattice(counts, spacing, origin=(0, 0, 0)):
    """(n, 3) points of a regular grid, x fastest."""
    nx, ny, nz = counts
    z, y, x = np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij")
    return (np.stack([x, y, z], -1).reshape(-1, 3) * spacing + np.asarray(origin)).astype(np.float32)


def static(world, env, shapes, name="static"):
    e = world.create_entity(env=env, name=name)
    e.add(cressim.Transform())
    e.add(cressim.Collider(shapes))
    return e


def open_box(world, env, inner_half, wall=0.05, height=1.0, name="container"):
    """A floor plane and four walls around [-ix, ix] x [-iy, iy], from z = 0 to `height`."""
    ix, iy = inner_half
    h = height / 2
    shapes = [cressim.Shape.plane(),
              cressim.Shape.box((wall, iy + 2 * wall, h), position=(ix + wall, 0, h)),
              cressim.Shape.box((wall, iy + 2 * wall, h), position=(-ix - wall, 0, h)),
              cressim.Shape.box((ix, wall, h), position=(0, iy + wall, h)),
              cressim.Shape.box((ix, wall, h), position=(0, -iy - wall, h))]
    return static(world, env, shapes, name)


def step(engine, frames):
    for _ in range(frames):
        engine.step_physics()
        engine.end_frame()


def positions(engine):
    return engine.buffer("particles.positions").read()[:, :3].copy()


def tet_volume(points, tets):
    a, b, c, d = (points[tets[:, k]] for k in range(4))
    return np.einsum("ij,ij->i", b - a, np.cross(c - a, d - a)).sum() / 6


def twist_angle(q0, q1):
    """Angle of the rotation from frame q0 to q1 about their common z (xyzw quaternions)."""
    x0, y0, z0, w0 = -q0[0], -q0[1], -q0[2], q0[3]
    x1, y1, z1, w1 = q1
    w = w0 * w1 - x0 * x1 - y0 * y1 - z0 * z1
    z = w0 * z1 + w1 * z0 + x0 * y1 - y0 * x1
    return 2 * math.atan2(z, w)
