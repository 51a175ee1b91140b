"""Where a twin tick over tissue goes: wall time of a tick (no sensors) beside the GPU
milliseconds of its frame ops (engine timestamps), for the kinematic and the dynamic arm, and
optionally other particle solver settings, so a slow tick can be put on the GPU's dispatches or on
the host.

    PYTHONPATH=python python3 benchmarks/profile_twin.py --scene psm_retraction.yaml \
        --physics-rates 200,800 --iterations 4/4,2/1 [--json OUT]

`--iterations I/C`: particle_iterations I with contacts in C of them (the twin's default 4/4).
`--host N`: also the N functions that took the most host time in the timed ticks (cProfile,
their own time, the engine's end_frame wait included as `end_frame`).
"""
from __future__ import annotations

import argparse
import cProfile
import json
import pstats
import time
from collections import defaultdict

import numpy as np
import torch

from cressim.twin import TwinArms, TwinConfig
from cressim.twin_scene_file import load_scene


def profile(scene: str, dynamics: str, rate: float, iterations: str, ticks: int, host: int = 0,
            particle_rate: float | None = None) -> dict:
    arms = TwinArms(TwinConfig(scene=load_scene(scene), dynamics=dynamics, physics_rate=rate, camera_width=64,
                               camera_height=48, particle_rate=particle_rate))
    engine = arms.bodies.engine
    if iterations:
        i, c = map(int, iterations.split("/"))
        physics = engine.physics
        physics.particle_iterations, physics.particle_contact_iterations = i, c
        engine.physics = physics
    arms.state_command(0, "enable")
    arms.state_command(0, "home")
    while arms.states[0].is_busy:
        arms.tick()
    for _ in range(20):
        arms.tick()
    profiler = cProfile.Profile() if host else None
    t0 = time.perf_counter()
    if profiler:
        profiler.enable()
    for _ in range(ticks):
        arms.tick()
        arms.snapshot()
    wall_ms = (time.perf_counter() - t0) * 1e3 / ticks
    if profiler:
        profiler.disable()
    engine.profiling = True
    ops = defaultdict(float)
    for _ in range(ticks):
        arms.tick()
        for label, ms in engine.last_timings:
            ops[label] += ms / ticks
    engine.profiling = False
    row = {"scene": scene, "dynamics": dynamics, "physics_rate": rate, "particle_rate": arms.particle_rate,
           "iterations": iterations or "scene's",
           "wall_ms_per_tick": wall_ms, "gpu_ms": dict(ops), "gpu_ms_total": sum(ops.values()),
           "device": engine.device["name"]}
    if profiler:
        stats = pstats.Stats(profiler).stats  # (file, line, name) -> (calls, ncalls, own s, cumulative s, callers)
        top = sorted(stats.items(), key=lambda kv: -kv[1][2])[:host]
        row["host_ms"] = {f"{fn[2]} ({fn[0].rsplit('/', 1)[-1]}:{fn[1]})": v[2] * 1e3 / ticks for fn, v in top}
    return row


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="psm_retraction.yaml")
    ap.add_argument("--dynamics", default="kinematic,dynamic")
    ap.add_argument("--physics-rates", default="200,800")
    ap.add_argument("--iterations", default="", help="comma-separated I/C settings; default the scene's")
    ap.add_argument("--ticks", type=int, default=100)
    ap.add_argument("--particle-rate", type=float, help="the particles' rate in Hz (default: the scene's)")
    ap.add_argument("--host", type=int, default=0, help="also list the N functions with the most host time")
    ap.add_argument("--json")
    args = ap.parse_args()
    torch.set_num_threads(1)
    rows = []
    for dynamics in args.dynamics.split(","):
        for rate in map(float, args.physics_rates.split(",")):
            for iterations in args.iterations.split(",") if args.iterations else [""]:
                row = profile(args.scene, dynamics, rate, iterations, args.ticks, args.host,
                              args.particle_rate)
                rows.append(row)
                ops = ", ".join(f"{k} {v:.2f}" for k, v in row["gpu_ms"].items() if v >= 0.01)
                print(f"{dynamics:9s} {rate:5.0f} Hz (particles {row['particle_rate']:.0f} Hz), iterations {row['iterations']}: {row['wall_ms_per_tick']:.2f} ms a "
                      f"tick, GPU {row['gpu_ms_total']:.2f} ms ({ops})", flush=True)
                for name, ms in row.get("host_ms", {}).items():
                    print(f"    host {ms:7.3f} ms  {name}", flush=True)
                if args.json:
                    with open(args.json, "w") as f:
                        json.dump(rows, f, indent=2)


if __name__ == "__main__":
    main()
