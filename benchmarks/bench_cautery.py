"""Throughput of `cressim demo cautery`'s scene (a 60 x 40 x 10 mm liver slab, 2,125 particles and
9,216 tets an env, an energized hook on it) at several env counts: physics steps with the hook
energized (heat cycles, coagulation pass) against the same slab without heat, env-steps per
second. No rendering (the cameras are authored but not drawn).

    PYTHONPATH=python python3 benchmarks/bench_cautery.py --envs 1,64,1024 [--json OUT]
"""
from __future__ import annotations

import argparse
import json
import time

import cressim
from cressim.demos import cautery as demo
from cressim.passes.cautery import Cautery


def measure(envs: int, heat: bool, frames: int) -> dict:
    world = cressim.World(cressim.SceneLayout(envs))
    table_mesh = world.add_mesh(cressim.Mesh.plane(0.1))
    hooks = [demo.author_env(world, env, table_mesh, 64, 48, heat=heat) for env in range(envs)]
    engine = cressim.Engine(world)
    engine.physics = cressim.PhysicsSettings(substeps=2, particle_iterations=2)
    engine.prepare()
    engine.upload_world()
    cautery = None
    if heat:
        cautery = Cautery(engine, hooks, (0, 0, 0), demo.RADIUS, power=demo.POWER)
        cautery.set([True] * envs)

    def frame():
        if cautery:
            cautery.execute()
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
    return {"envs": envs, "heat": heat, "frames": frames, "seconds": seconds, "env_steps_per_s": envs * frames / seconds,
            "particles_per_env": int(engine.buffer("particles.positions").shape[0]) // envs,
            "device": engine.device["name"], "health_events": int(engine.health_events)}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--envs", default="1,64,1024")
    ap.add_argument("--frames", type=int, default=200)
    ap.add_argument("--json")
    args = ap.parse_args()
    rows = []
    for envs in map(int, args.envs.split(",")):
        for heat in (True, False):
            row = measure(envs, heat, args.frames)
            rows.append(row)
            print(f"{envs:5d} envs, heat {'on ' if heat else 'off'}: {row['env_steps_per_s']:,.0f} env-steps/s "
                  f"({row['seconds'] / args.frames * 1e3:.2f} ms a step) on {row['device']}", flush=True)
            if args.json:
                with open(args.json, "w") as f:
                    json.dump(rows, f, indent=2)


if __name__ == "__main__":
    main()
