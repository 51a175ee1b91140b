"""Small particle scenes for the particle tests (z up, SI units)."""
import numpy as np

import cressim


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


def start(world, make_engine, **settings):
    engine = make_engine(world)
    if settings:
        engine.physics = cressim.PhysicsSettings(**settings)
    engine.prepare()
    engine.upload_world()
    return engine


def step(engine, frames):
    for _ in range(frames):
        engine.step_physics()
        engine.end_frame()


def positions(engine):
    return engine.buffer("particles.positions").read()[:, :3].copy()


def tet_volume(points, tets):
    a, b, c, d = (points[tets[:, k]] for k in range(4))
    return np.einsum("ij,ij->i", b - a, np.cross(c - a, d - a)).sum() / 6
