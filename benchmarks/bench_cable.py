"""Throughput of `cressim demo cable`'s scene (a 100 mm NiTi backbone of 21 particles, 11 disks, four
tendons, over a table; no disk or tendon visuals) at several env counts, with the tendons sweeping
the tip round (displacement mode: the tendon pass runs every solver iteration), env-steps per
second. No rendering.

    PYTHONPATH=python python3 benchmarks/bench_cable.py --envs 1,64,1024 [--json OUT]
"""
from __future__ import annotations

import argparse
import json
import math
import time

import numpy as np

import cressim
from cressim.demos import cable as demo
from cressim.tendons import TendonDrive


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

    for _ in range(20):
        frame()
    engine.buffer("particles.positions").read()  # waits for the GPU
    t0 = time.perf_counter()
    for _ in range(frames):
        frame()
    engine.buffer("particles.positions").read()
    seconds = time.perf_counter() - t0
    return {"envs": envs, "frames": frames, "seconds": seconds, "env_steps_per_s": envs * frames / seconds,
            "particles_per_env": int(engine.buffer("particles.positions").shape[0]) // envs,
            "device": engine.device["name"], "health_events": int(engine.health_events)}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--envs", default="1,64,1024")
    ap.add_argument("--frames", type=int, default=300)
    ap.add_argument("--json")
    args = ap.parse_args()
    rows = []
    for envs in map(int, args.envs.split(",")):
        row = measure(envs, args.frames)
        rows.append(row)
        print(f"{envs:5d} envs: {row['env_steps_per_s']:,.0f} env-steps/s ({row['seconds'] / args.frames * 1e3:.2f} ms a "
              f"step, health events {row['health_events']}) on {row['device']}", flush=True)
        if args.json:
            with open(args.json, "w") as f:
                json.dump(rows, f, indent=2)


if __name__ == "__main__":
    main()
