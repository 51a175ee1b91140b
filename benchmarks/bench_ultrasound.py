"""Ultrasound sensor throughput alone, one step_simulation_sensors per frame, synchronised every
frame: images/s, scatterers projected per second, GPU ms per frame (engine timestamps),
scatterers and particles per env. Writes JSON.
Scenes: the UltrasoundScan task's (default; paper's sizes: 130 x 160 image, 96 scanlines 0.006
apart, 0.7 long, a 0.45 tissue cube with 1e6 scatterers per unit volume, carried by the tets of
a 343-particle soft body), or with --scatterers N a rigid gel phantom of N scatterers per env
(50 x 20 x 50 mm: 20 per mm^3 at 1 M) under the default probe (sector, 128 lines, 15 cm, 256 x 200).
Usage: PYTHONPATH=python python3 benchmarks/bench_ultrasound.py --envs 1,32,256,1024,4096
       PYTHONPATH=python python3 benchmarks/bench_ultrasound.py --envs 1,32,1024 --scatterers 1000000"""
from __future__ import annotations

import argparse
import gc
import json
import time
from pathlib import Path

import cressim
from cressim.envs.ultrasound_scan import UltrasoundScan


def phantom(envs: int, scatterers: int) -> cressim.World:
    world = cressim.World(cressim.SceneLayout(envs))
    for env in range(envs):
        t = world.create_entity(env=env, name="phantom")
        t.add(cressim.Transform(position=(0, 0, 0.05)))
        t.add(cressim.UltrasoundTissue(region="box", size=(0.025, 0.01, 0.025), count=scatterers))
        p = world.create_entity(env=env, name="probe")
        p.add(cressim.Transform())
        p.add(cressim.UltrasoundProbe())
    return world


def build(envs: int, scatterers: int) -> cressim.Engine:
    engine = cressim.Engine(phantom(envs, scatterers) if scatterers else UltrasoundScan.scene(envs))
    engine.prepare()
    engine.upload_world()
    return engine


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--envs", default="1,8,32,64,256,1024,4096")
    ap.add_argument("--scatterers", type=int, default=0, help="per env, in a rigid phantom (0: UltrasoundScan)")
    ap.add_argument("--frames", type=int, default=100)
    ap.add_argument("--json", default="benchmarks/results/ultrasound_sensor.json")
    args = ap.parse_args()
    rows = []
    for envs in map(int, args.envs.split(",")):
        t = time.perf_counter()
        engine = build(envs, args.scatterers)
        setup = time.perf_counter() - t
        for _ in range(10):
            engine.step_simulation_sensors()
            engine.end_frame()
        t = time.perf_counter()
        for _ in range(args.frames):
            engine.step_simulation_sensors()
            engine.end_frame()
        dt = (time.perf_counter() - t) / args.frames
        engine.profiling = True
        engine.step_simulation_sensors()
        engine.end_frame()
        gpu_ms = sum(ms for _, ms in engine.last_timings)
        scatterers = int(engine.ultrasound_probes["scatterers"])
        particles = engine.buffer("particles.positions").shape[0] / envs if args.scatterers == 0 else 0
        mem = sum(engine.buffer(k).nbytes for k in engine.internal_keys if k.startswith("ultrasound")) / envs
        rows.append({"envs": envs, "images_per_s": envs / dt, "frames_per_s": 1 / dt, "gpu_ms_per_frame": gpu_ms,
                     "scatterers_per_s": scatterers / dt, "gpu_scatterers_per_s": scatterers / gpu_ms * 1e3,
                     "scatterers": scatterers, "scatterers_per_env": scatterers / envs, "particles_per_env": particles,
                     "sensor_bytes_per_env": mem, "setup_s": setup, "device": engine.device["name"]})
        print(f"{envs:6d} envs: {envs / dt:12,.0f} images/s ({1 / dt:8.1f} frames/s, GPU {gpu_ms:7.3f} ms/frame), "
              f"{scatterers / envs:,.0f} scatterers/env ({scatterers / dt:.3g}/s), {mem / 2**20:.2f} MiB/env, "
              f"setup {setup:.1f} s", flush=True)
        del engine
        gc.collect()
    out = Path(args.json)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"command": "bench_ultrasound.py", "frames": args.frames, "scatterers": args.scatterers, "results": rows}, indent=1))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
