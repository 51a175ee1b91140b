"""Frames of a plain engine with a Randomizer, as VectorEnv records them."""
import numpy as np


def randomized_frame(engine, randomizer, reset_all=False, physics=True, sensors=()):
    """One frame: draw, reset, write the draws, then physics and `sensors` (engine methods)."""
    randomizer.sample(reset_all)
    engine.reset_flagged_envs()
    randomizer.apply()
    if physics:
        engine.step_physics()
    for s in sensors:
        getattr(engine, s)()
    randomizer.after_sensors()
    engine.end_frame()


def steps(engine, frames, record):
    out = []
    for _ in range(frames):
        engine.step_physics()
        engine.end_frame()
        out.append(record(engine))
    return np.array(out)
