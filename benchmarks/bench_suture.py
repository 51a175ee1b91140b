"""Throughput of `cressim demo suture`'s scene (two 24 x 30 x 8 mm flaps of 396 particles each, a
needle carrying 160 mm of thread of 81 particles, over a table; no camera) at several env counts,
while the needle turns through the first bite (the puncture detection and solve run every substep
and iteration), env-steps per second. No rendering.

    PYTHONPATH=python python3 benchmarks/bench_suture.py --envs 1,64,1024 [--json OUT]
"""
from __future__ import annotations

import argparse
import json
import time

import cressim
from cressim.demos import suture as demo
from cressim.suture import PUNCTURED, punctures


def measure(envs: int, frames: int) -> dict:
    world = cressim.World(cressim.SceneLayout(envs))
    meshes = {"table": world.add_mesh(cressim.Mesh.plane(0.1)),
              "needle": world.add_mesh(demo.needle_mesh(demo.RADIUS, demo.ANGLE, 0.00035))}
    needles = [demo.author_env(world, env, meshes, 64, 48, camera=False) for env in range(envs)]
    engine = cressim.Engine(world)
    engine.prepare()
    engine.upload_world()
    steps = [s for s in demo.motion(engine.physics.dt) if s[0] == "bite1"]

    def frame(k):
        _, centre, theta = steps[k % len(steps)]
        t = cressim.Transform(position=tuple(centre), rotation=demo._quat(theta))
        for needle in needles:
            needle.transform = t
        engine.step_physics()
        engine.end_frame()

    for k in range(20):
        frame(k)
    engine.buffer("particles.positions").read()  # waits for the GPU
    t0 = time.perf_counter()
    for k in range(frames):
        frame(20 + k)
    engine.buffer("particles.positions").read()
    seconds = time.perf_counter() - t0
    live = sum(1 for r in punctures(engine)[0] if r["state"] == PUNCTURED)
    return {"envs": envs, "frames": frames, "seconds": seconds, "env_steps_per_s": envs * frames / seconds,
            "particles_per_env": int(engine.buffer("particles.positions").shape[0]) // envs,
            "punctured_env0": live, "device": engine.device["name"], "health_events": int(engine.health_events)}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--envs", default="1,64,1024")
    ap.add_argument("--frames", type=int, default=120)
    ap.add_argument("--json")
    args = ap.parse_args()
    rows = []
    for envs in map(int, args.envs.split(",")):
        row = measure(envs, args.frames)
        rows.append(row)
        print(f"{envs:5d} envs: {row['env_steps_per_s']:,.0f} env-steps/s ({row['seconds'] / args.frames * 1e3:.2f} ms a "
              f"step; env 0 has {row['punctured_env0']} punctured points; health events {row['health_events']}) on "
              f"{row['device']}", flush=True)
        if args.json:
            with open(args.json, "w") as f:
                json.dump(rows, f, indent=2)


if __name__ == "__main__":
    main()
