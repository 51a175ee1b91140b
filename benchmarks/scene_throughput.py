"""What the demo-scene benchmarks share (bench_cable, bench_cautery, bench_suture): a frame timed
after a warm-up, a result row, and the command line (--envs, --frames, --json) that measures each
env count and variant, prints it and writes the rows as JSON after each."""
from __future__ import annotations

import argparse
import json
import time


def timed(engine, frame, envs: int, frames: int, warmup: int = 20, **extra) -> dict:
    """Runs `frame()` `warmup` times, then `frames` times on the clock (the GPU waited for at both
    ends): the row of env-steps per second."""
    for _ in range(warmup):
        frame()
    engine.buffer("particles.positions").read()  # waits for the GPU
    t0 = time.perf_counter()
    for _ in range(frames):
        frame()
    engine.buffer("particles.positions").read()
    seconds = time.perf_counter() - t0
    return {"envs": envs, "frames": frames, "seconds": seconds, "env_steps_per_s": envs * frames / seconds,
            "particles_per_env": int(engine.buffer("particles.positions").shape[0]) // envs,
            "device": engine.device["name"], "health_events": int(engine.health_events), **extra}


def main(doc: str, measure, frames: int, variants=({},)):
    """`measure(envs, frames, **variant)` -> a row (timed()), for every env count and variant."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--envs", default="1,64,1024")
    ap.add_argument("--frames", type=int, default=frames)
    ap.add_argument("--json")
    args = ap.parse_args()
    rows = []
    for envs in map(int, args.envs.split(",")):
        for variant in variants:
            row = measure(envs, args.frames, **variant)
            rows.append(row)
            label = "".join(f", {k} {v}" for k, v in variant.items())
            print(f"{envs:5d} envs{label}: {row['env_steps_per_s']:,.0f} env-steps/s "
                  f"({row['seconds'] / args.frames * 1e3:.2f} ms a step, health events {row['health_events']}) "
                  f"on {row['device']}", flush=True)
            if args.json:
                with open(args.json, "w") as f:
                    json.dump(rows, f, indent=2)
