"""Particles drawn by the renderer: the SoftBodyPush and FluidPour worlds (../shared/TASKS.md
workloads, python/cressim/envs) with one camera per env (64x64 unless --size), a sun, and the
task's physics settings; per frame one step_physics and one step_visual_sensors, synchronised
every frame. Reports frames/s and camera images/s with the camera and, for the cost of drawing,
physics alone on the same world without cameras; GPU ms per frame, and per stage
(step_physics, step_visual_sensors), from the engine's timings.
Usage: python benchmarks/bench_particle_render.py --tasks SoftBodyPush,FluidPour --envs 64,256,1024
       --raster compute --json benchmarks/results/particle_render.json"""
from __future__ import annotations

import argparse
import json
import os
import time

import cressim
from cressim.envs.fluid_pour import FluidPour
from cressim.envs.soft_body_push import SoftBodyPush
from cressim.scene_file import _quat_look_at

TASKS = {"SoftBodyPush": SoftBodyPush, "FluidPour": FluidPour}
VIEWS = {"SoftBodyPush": ((0, -2.2, 1.4), (0, 0, 0.2)),  # (eye, target): the cube and the pusher
         "FluidPour": ((0, -4.5, 2.2), (0, 0, 0.8))}      # both containers


def build(task: str, envs: int, size: int, camera: bool) -> cressim.Engine:
    cls = TASKS[task]
    owner = cls.__new__(cls)  # the task's scene and settings without its passes
    world = owner.build_world(envs)
    for env in range(envs):
        if not camera:
            break
        sun = world.create_entity(env=env, name="sun")
        sun.add(cressim.Transform(position=(0, 0, 2), rotation=_quat_look_at((0, 0, 2), (0.4, 0.3, 0))))  # travels down
        sun.add(cressim.Light())
        cam = world.create_entity(env=env, name="camera")
        eye, target = VIEWS[task]
        cam.add(cressim.Transform(position=eye, rotation=_quat_look_at(eye, target)))
        cam.add(cressim.Camera(width=size, height=size, fov_y=50))
    engine = cressim.Engine(world)
    engine.physics = owner.physics_settings()
    engine.prepare()
    engine.upload_world()
    return engine


def measure(task: str, envs: int, args, camera: bool) -> dict:
    os.environ["CRESSIM_RASTER"] = args.raster  # read when the renderer is built (upload_world)
    engine = build(task, envs, args.size, camera)

    def frame():
        engine.step_physics()
        if camera:
            engine.step_visual_sensors()
        engine.end_frame()

    for _ in range(10):
        frame()
    engine.profiling = True
    t = time.perf_counter()
    for _ in range(args.frames):
        frame()
    dt = (time.perf_counter() - t) / args.frames
    timings = {}
    for name, ms in engine.last_timings:
        timings[name] = timings.get(name, 0.0) + ms
    label = f"{task:12s} {envs:6d} envs {'camera ' + str(args.size) + '^2' if camera else 'physics only':14s}"
    print(f"{label}: {1 / dt:8.1f} frames/s, {envs / dt:12,.0f} env-steps/s, GPU {sum(timings.values()):7.2f} ms/frame",
          flush=True)
    return {"task": task, "envs": envs, "camera": camera, "size": args.size, "raster": args.raster,
            "frames_per_s": 1 / dt, "env_steps_per_s": envs / dt, "gpu_ms_per_frame": sum(timings.values()),
            "gpu_ms_by_stage": timings, "device": engine.device["name"]}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--tasks", default="SoftBodyPush,FluidPour")
    ap.add_argument("--envs", default="64,256,1024")
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--frames", type=int, default=50)
    ap.add_argument("--raster", default="auto", choices=("auto", "graphics", "compute"))
    ap.add_argument("--json")
    args = ap.parse_args()
    rows = []
    for task in args.tasks.split(","):
        for envs in map(int, args.envs.split(",")):
            for camera in (False, True):
                rows.append(measure(task, envs, args, camera))
                if args.json:  # after every row: a run cut off by its time limit keeps what it measured
                    os.makedirs(os.path.dirname(os.path.abspath(args.json)), exist_ok=True)
                    with open(args.json, "w") as f:
                        json.dump(rows, f, indent=2)


if __name__ == "__main__":
    main()
