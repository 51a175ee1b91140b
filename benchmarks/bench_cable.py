"""Throughput of `cressim demo cable`'s scene (a 100 mm NiTi backbone of 21 particles, 11 disks, four
tendons, over a table; no disk or tendon visuals) at several env counts, with the tendons sweeping
the tip round (displacement mode: the tendon pass runs every solver iteration), env-steps per
second. No rendering.

    PYTHONPATH=python python3 benchmarks/bench_cable.py --envs 1,64,1024 [--json OUT]
"""
from __future__ import annotations

import math

import numpy as np

import cressim
from cressim.demos import cable as demo
from cressim.tendons import TendonDrive
from scene_throughput import main, timed


def measure(envs: int, frames: int) -> dict:
    world = cressim.World(cressim.SceneLayout(envs))
    meshes = {"table": world.add_mesh(cressim.Mesh.plane(0.2)), "base": world.add_mesh(cressim.Mesh.box((0.012, 0.02, 0.02)))}
    for env in range(envs):
        demo.author_env(world, env, meshes, 64, 48)
    engine = cressim.Engine(world)
    engine.prepare()
    engine.upload_world()
    drive = TendonDrive(engine)
    # each env's pulls a different phase of the sweep, written once (the commands stay on the GPU)
    phase = 2 * math.pi * np.arange(envs)[:, None] / envs
    a, b = demo.SWEEP * np.cos(phase), demo.SWEEP * np.sin(phase)
    drive.pull(np.concatenate([a, b, -a, -b], 1))

    def frame():
        engine.step_physics()
        engine.end_frame()

    return timed(engine, frame, envs, frames)


if __name__ == "__main__":
    main(__doc__, measure, frames=300)
