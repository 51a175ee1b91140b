"""The twin's control tick and sensors without ROS, as the node runs them: N PSM arms
(cressim.twin.TwinArms: trajectories, measured, batched FK/Jacobians and the one device -> host
snapshot a tick publishes) ticked by a 100 Hz loop, while cressim.twin.SensorLoop renders each
env's camera (the default scene's 640x480 RGB, depth and segmentation at 30 Hz) on its own
thread and copies the images to the host, as the node does before publishing them.

Two figures per row:
- paced: the tick loop runs in real time at 100 Hz for --seconds; tick time (mean, max), the
  tick rate held, and camera frames rendered per second (the rest skipped: a frame is never
  waited for);
- unpaced: ticks back to back without cameras (the tick's own cost), ticks/s and env-ticks/s.

`--scene psm_retraction.yaml` runs the twin over tissue (a world file: the engine steps every
tick, the flap's particles with it); `--physics-rate 800` as a dynamic arm holding tissue needs,
`--particle-rate 200` the flap's particles at 200 Hz meanwhile.

Usage (GPU machine, after benchmarks/gpu_build.sh; needs yourdfpy, trimesh):
    PYTHONPATH=python python3 benchmarks/bench_twin.py --envs 1,64,1024 --json benchmarks/results/twin_<gpu>.json
On the development machine (lavapipe) use small counts: --envs 1 --seconds 5.
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np
import torch

from cressim.twin import JointCommand, Scene, Sensor, SensorLoop, TwinArms, TwinConfig
from cressim.twin_scene_file import load_scene
from cressim.twin.camera_images import PRODUCTS, CameraImages


def _drive(arms, k: int):
    """Every env's yaw on its own sine (a servo_jp per env, as clients would send)."""
    for env in range(min(arms.num_envs, 8)):  # commands are per env; a few keep the loop O(1)
        q = [0.3 * np.sin(0.05 * k + env), 0.0, 0.12, 0.0, 0.0, 0.0]
        arms.servo_jp(env, JointCommand(position=q))



def paced(twin, sensors, drive, seconds: float, camera: str) -> dict:
    """`twin` (TwinArms or Cart) ticked at its publish rate for `seconds` of wall time, driven by
    `drive(twin, tick)`, its sensor loop offered every tick: the tick's cost, the rate reached
    and the camera frames rendered and skipped (keys named after `camera`)."""
    period, ticks, tick_s = 1.0 / twin.publish_rate, 0, []
    start = next_t = time.perf_counter()
    while time.perf_counter() - start < seconds:
        a = time.perf_counter()
        drive(twin, ticks)
        twin.tick()
        twin.snapshot()
        sensors.offer(twin.sim_ns, stamp=ticks)
        tick_s.append(time.perf_counter() - a)
        ticks += 1
        next_t += period
        time.sleep(max(0.0, next_t - time.perf_counter()))
    elapsed = time.perf_counter() - start
    sensors.wait_idle(60)
    stats = sensors.stats()["camera"]
    sensors.close()
    return {"paced_tick_mean_ms": float(np.mean(tick_s)) * 1e3, "paced_tick_max_ms": float(np.max(tick_s)) * 1e3,
            "paced_ticks_per_s": ticks / elapsed, f"{camera}_frames_per_s": stats["rendered"] / elapsed,
            f"{camera}_frames_skipped": stats["skipped"], "seconds": elapsed}

def _ready(arms):
    for env in range(arms.num_envs):
        arms.state_command(env, "enable")
        arms.state_command(env, "home")
    while any(s.is_busy for s in arms.states):
        arms.tick()


def run(envs: int, dynamics: str, width: int, height: int, camera_rate: float, seconds: float, scene: str = "",
        physics_rate: float | None = None, particle_rate: float | None = None) -> dict:
    t0 = time.perf_counter()
    arms = TwinArms(TwinConfig(scene=load_scene(scene) if scene else Scene(), num_envs=envs, dynamics=dynamics, camera_width=width,
                               camera_height=height, cameras=width > 0, physics_rate=physics_rate,
                               particle_rate=particle_rate))
    build_s = time.perf_counter() - t0
    _ready(arms)
    row = {"envs": envs, "dynamics": dynamics, "scene": scene or "default", "physics_rate": arms.physics_rate,
           "particle_rate": arms.particle_rate, "camera": f"{width}x{height}" if width else "none",
           "camera_rate": camera_rate, "build_s": build_s, "device": arms.bodies.engine.device["name"],
           "engine_torch_device": str(arms.bodies.device)}

    # unpaced: the tick's own cost (no sensors)
    n = 200
    t = time.perf_counter()
    for k in range(n):
        _drive(arms, k)
        arms.tick()
        arms.snapshot()
    dt = (time.perf_counter() - t) / n
    row.update(unpaced_tick_ms=dt * 1e3, unpaced_ticks_per_s=1 / dt, unpaced_env_ticks_per_s=envs / dt)

    if width:
        images = CameraImages(arms.bodies.engine)
        sensors = SensorLoop(arms, [Sensor("camera", camera_rate, render=True, read=lambda: images.grab(PRODUCTS),
                                           publish=lambda raw, stamp: images.convert(raw))])
        sensors.render_now()  # pipelines built before timing
        if arms.bodies.device.type == "cpu" and not arms.dynamic:
            sensors.lower_priority(arms.engine_threads)
        row.update(paced(arms, sensors, _drive, seconds, "camera"))
    row["unhealthy_envs"] = int((arms.bodies.health_flags() != 0).sum())
    return row


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--envs", default="1,64,1024")
    ap.add_argument("--dynamics", default="kinematic,dynamic")
    ap.add_argument("--camera", default="640x480", help="WxH of each env's camera (the default scene's); 0: none")
    ap.add_argument("--camera-rate", type=float, default=30.0)
    ap.add_argument("--seconds", type=float, default=10.0, help="paced run length")
    ap.add_argument("--scene", default="", help="a twin file (e.g. psm_retraction.yaml); default: the built-in scene")
    ap.add_argument("--physics-rate", type=float, help="engine rate in Hz (default: the scene's)")
    ap.add_argument("--particle-rate", type=float, help="the particles' rate in Hz (default: the scene's)")
    ap.add_argument("--json")
    args = ap.parse_args()
    torch.set_num_threads(1)  # as the node: (N, 6) tensors gain nothing from threads
    width, height = (0, 0) if args.camera == "0" else map(int, args.camera.split("x"))
    rows = []
    for dynamics in args.dynamics.split(","):
        for envs in map(int, args.envs.split(",")):
            row = run(envs, dynamics, width, height, args.camera_rate, args.seconds, args.scene, args.physics_rate,
                      args.particle_rate)
            rows.append(row)
            paced = (f"paced: {row['paced_ticks_per_s']:.1f} ticks/s, tick {row['paced_tick_mean_ms']:.2f} ms "
                     f"(max {row['paced_tick_max_ms']:.1f}), camera {row['camera_frames_per_s']:.1f} frames/s "
                     f"({row['camera_frames_skipped']} skipped); " if width else "")
            print(f"{dynamics:9s} {envs:5d} envs, {row['physics_rate']:.0f} Hz physics "
                  f"({row['particle_rate']:.0f} Hz particles): {paced}unpaced {row['unpaced_ticks_per_s']:,.0f} ticks/s = "
                  f"{row['unpaced_env_ticks_per_s']:,.0f} env-ticks/s; built in {row['build_s']:.1f} s; "
                  f"unhealthy {row['unhealthy_envs']}", flush=True)
            if args.json:  # after every row: a later crash keeps the rows before it
                with open(args.json, "w") as f:
                    json.dump(rows, f, indent=2)


if __name__ == "__main__":
    main()
