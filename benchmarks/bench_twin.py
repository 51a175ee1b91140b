"""The twin's batched headless mode without ROS: N PSM arms in one engine, ticked as the node
ticks them (batched FK of every env's links, body targets written on the device, one submit of
physics substeps, in dynamic mode joint drives set and joint values gathered), with and without
each env's camera rendering every tick. Prints and writes ticks/s and env-ticks/s.

Usage (GPU machine, after benchmarks/gpu_build.sh; needs yourdfpy and pytorch-kinematics):
    PYTHONPATH=python:ros_ws/src/cressim_ros python3 benchmarks/bench_twin.py --envs 1,64,1024,4096 \
        --json benchmarks/results/twin_<gpu>.json
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np
import torch

from cressim.robots import robot_dir
from cressim_ros.arm_bodies import ArmBodies
from cressim_ros.scenery import CameraSpec

Q0 = np.array([0.0, 0.0, 0.1, 0.0, 0.0, 0.0])


def run(envs: int, dynamics: str, camera: int, ticks: int, device) -> dict:
    spec = CameraSpec(width=camera, height=camera) if camera else None
    t0 = time.perf_counter()
    arms = ArmBodies(robot_dir() / "psm_lnd.urdf", envs, base_position=(0, 0, 0.3), base_rotation=(0, 0, 0, 1),
                     publish_rate=100, physics_rate=200, initial_q=Q0, initial_jaw=0.0, dof=6, dynamics=dynamics,
                     camera=spec, device=device)
    build_s = time.perf_counter() - t0
    dev = arms.device
    q = torch.as_tensor(Q0, device=dev, dtype=torch.float64).repeat(envs, 1)
    jaw = torch.zeros(envs, 1, device=dev, dtype=torch.float64)
    phase = torch.linspace(0, 6.28, envs, device=dev, dtype=torch.float64)

    def tick(k):
        qk = q.clone()
        qk[:, 0] = 0.3 * torch.sin(phase + 0.05 * k)  # every env's yaw on its own sine
        if arms.dynamic:
            arms.set_targets(qk, jaw)
        arms.write(qk, jaw)
        arms.step(render=bool(camera))
        if arms.dynamic:
            arms.read_joints()

    for k in range(10):
        tick(k)
    if dev.type == "cuda":
        torch.cuda.synchronize(dev)
    t = time.perf_counter()
    for k in range(ticks):
        tick(k)
    if dev.type == "cuda":
        torch.cuda.synchronize(dev)
    dt = (time.perf_counter() - t) / ticks
    health = int((arms.health_flags() != 0).sum())
    return {"envs": envs, "dynamics": dynamics, "camera": camera, "ticks_per_s": 1 / dt, "env_ticks_per_s": envs / dt,
            "tick_ms": dt * 1e3, "build_s": build_s, "unhealthy_envs": health,
            "device": arms.engine.device["name"], "torch_device": str(dev)}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--envs", default="1,64,1024")
    ap.add_argument("--dynamics", default="kinematic,dynamic")
    ap.add_argument("--cameras", default="0,64", help="camera sizes (square); 0: no camera")
    ap.add_argument("--ticks", type=int, default=100)
    ap.add_argument("--device", default=None, help="torch device (default: the engine's)")
    ap.add_argument("--json")
    args = ap.parse_args()
    rows = []
    for dynamics in args.dynamics.split(","):
        for camera in map(int, args.cameras.split(",")):
            for envs in map(int, args.envs.split(",")):
                row = run(envs, dynamics, camera, args.ticks, args.device)
                rows.append(row)
                print(f"{dynamics:9s} camera {camera:3d}  {envs:5d} envs: {row['ticks_per_s']:8.1f} ticks/s "
                      f"{row['env_ticks_per_s']:12,.0f} env-ticks/s ({row['tick_ms']:.2f} ms/tick, built in "
                      f"{row['build_s']:.1f} s, unhealthy {row['unhealthy_envs']})", flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=2)


if __name__ == "__main__":
    main()
