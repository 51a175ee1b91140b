"""Throughput of `cressim demo suture`'s scene (two 24 x 30 x 8 mm flaps of 396 particles each, a
needle carrying 160 mm of thread of 81 particles, over a table; no camera) at several env counts,
while the needle turns through the first bite (the puncture detection and solve run every substep
and iteration), env-steps per second. No rendering.

    PYTHONPATH=python python3 benchmarks/bench_suture.py --envs 1,64,1024 [--json OUT]
"""
from __future__ import annotations

import numpy as np

import cressim
from cressim.demos import suture as demo
from cressim.suture import PUNCTURED, punctures
from scene_throughput import main, timed


def measure(envs: int, frames: int) -> dict:
    world = cressim.World(cressim.SceneLayout(envs))
    meshes = {"table": world.add_mesh(cressim.Mesh.plane(0.1)),
              "needle": world.add_mesh(demo.needle_mesh(demo.RADIUS, demo.ANGLE, 0.00035))}
    for env in range(envs):
        demo.author_env(world, env, meshes, 64, 48, camera=False)
    engine = cressim.Engine(world)
    engine.prepare()
    engine.upload_world()
    steps = [s for s in demo.motion(engine.physics.dt) if s[0] == "bite1"]
    # every env's needle body moved by one write of the kinematic targets (no host loop over envs)
    rows = engine.buffer("particles.needles").read()[:, 0].astype(np.int64)
    positions, rotations = (engine.buffer(f"control.body_target_{k}") for k in ("positions", "rotations"))
    p, q = positions.read(), rotations.read()
    k = [0]

    def frame():
        _, centre, theta = steps[k[0] % len(steps)]
        k[0] += 1
        p[rows, :3] = centre
        q[rows] = demo._quat(theta)
        positions.write(p)
        rotations.write(q)
        engine.step_physics()
        engine.end_frame()

    row = timed(engine, frame, envs, frames)
    row["punctured_env0"] = sum(1 for r in punctures(engine)[0] if r["state"] == PUNCTURED)
    return row


if __name__ == "__main__":
    main(__doc__, measure, frames=120)
