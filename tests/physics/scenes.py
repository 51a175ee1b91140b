"""Small rigid-body scenes for the physics tests (z up, SI units)."""
import numpy as np

import cressim


def ground(world, env, friction=0.5):
    g = world.create_entity(env=env, name="ground")
    g.add(cressim.Transform())
    g.add(cressim.Collider(cressim.Shape.plane(), static_friction=friction))
    return g


def box(world, env, position, half=0.1, mass=1.0, friction=0.5, name="box", restitution=0.0):
    b = world.create_entity(env=env, name=name)
    b.add(cressim.Transform(position=position))
    b.add(cressim.RigidBody(mass=mass))
    b.add(cressim.Collider(cressim.Shape.box((half, half, half)), static_friction=friction, restitution=restitution))
    return b


def start(world, make_engine, **settings):
    engine = make_engine(world)
    if settings:
        engine.physics = cressim.PhysicsSettings(**settings)
    engine.prepare()
    engine.upload_world()
    return engine


def step(engine, frames, record=None):
    """Steps `frames` frames; `record(engine)` after each, collected into an array."""
    out = []
    for _ in range(frames):
        engine.step_physics()
        engine.end_frame()
        if record is not None:
            out.append(record(engine))
    return np.array(out)


def set_reset(engine, key, index, values, env=0):
    """Writes a control.* reset row and resets `env` with it."""
    buf = engine.buffer(key)
    v = buf.read()
    v[index, : len(values)] = values
    buf.write(v)
    engine.reset_envs([env])


def body(engine, key, i=0):
    return engine.buffer(key).read()[i]
