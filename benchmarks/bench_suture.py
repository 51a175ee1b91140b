"""Throughput of `cressim demo suture`'s scene (two 24 x 30 x 8 mm flaps of 396 particles each, a
needle carrying 160 mm of thread of 81 particles, over a table; no camera) at several env counts,
env-steps per second, in two phases: `bite`, the needle turning through the first bite (the
puncture detection and solve run every substep and iteration), and `tight`, after both bites with
the knot caught, the needle pulling the stitch on at 2 mm/s (the taut string solved every
iteration). No rendering.

    PYTHONPATH=python python3 benchmarks/bench_suture.py --envs 1,64,1024 [--json OUT]
"""
from __future__ import annotations

import numpy as np

import cressim
from cressim.demos import suture as demo
from cressim.suture import PUNCTURED, punctures, thread_tension
from scene_throughput import main, timed


def measure(envs: int, frames: int, phase: str = "bite") -> dict:
    world = cressim.World(cressim.SceneLayout(envs))
    meshes = {"table": world.add_mesh(cressim.Mesh.plane(0.1)),
              "needle": world.add_mesh(demo.needle_mesh(demo.RADIUS, demo.ANGLE, 0.00035))}
    for env in range(envs):
        demo.author_env(world, env, meshes, 64, 48, camera=False)
    engine = cressim.Engine(world)
    engine.prepare()
    engine.upload_world()
    dt = engine.physics.dt
    # every env's needle body moved by one write of the kinematic targets (no host loop over envs)
    rows = engine.buffer("particles.needles").read()[:, 0].astype(np.int64)
    positions, rotations = (engine.buffer(f"control.body_target_{k}") for k in ("positions", "rotations"))
    p, q = positions.read(), rotations.read()

    def place(centre, theta):
        p[rows, :3] = centre
        q[rows] = demo._quat(theta)
        positions.write(p)
        rotations.write(q)
        engine.step_physics()
        engine.end_frame()

    if phase == "bite":
        steps = [s for s in demo.motion(dt) if s[0] == "bite1"]
        k = [0]

        def frame():
            _, centre, theta = steps[k[0] % len(steps)]
            k[0] += 1
            place(centre, theta)
    else:  # the demo's bites and draw-out, then pulled until env 0's knot has caught (untimed)
        steps = demo.motion(dt)
        for _, centre, theta in steps:
            place(centre, theta)
        theta, _ = demo.needle_out(engine, place, steps[-1][1], steps[-1][2], dt)
        state = {"centre": np.asarray(steps[-1][1], float)}
        way = np.asarray(demo.PULL) / np.linalg.norm(demo.PULL)
        for _ in range(round(demo.PULL_LIMIT / dt)):
            if any(r["knot"] for r in punctures(engine)[0]):
                break
            state["centre"] = state["centre"] + way * demo.PULL_SPEED * dt
            place(state["centre"], theta)

        def frame():
            state["centre"] = state["centre"] + way * 0.002 * dt
            place(state["centre"], theta)

    row = timed(engine, frame, envs, frames, phase=phase)
    records = punctures(engine)[0]
    row["punctured_env0"] = sum(1 for r in records if r["state"] == PUNCTURED)
    row["knot_env0"] = any(r["knot"] for r in records)
    row["tension_env0_n"] = float(thread_tension(engine)[0])
    return row


if __name__ == "__main__":
    main(__doc__, measure, frames=120, variants=({"phase": "bite"}, {"phase": "tight"}))
