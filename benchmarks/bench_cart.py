"""The patient cart's tick and stereo endoscope without ROS, as the node runs them: the ECM, three
PSMs (scenes/patient_cart.yaml plus PSM3) in one engine, ticked by a 100 Hz loop, while
cressim.twin.SensorLoop renders both eyes (640x480 RGB, depth and segmentation each, at 30 Hz)
on its own thread and copies the images to the host, as the node does before publishing.

Printed and written (--json): unpaced tick time (every arm's tick and snapshot, no cameras),
paced tick mean/max at 100 Hz with the cameras on, ticks/s held, stereo frames/s rendered and
skipped, and one stereo frame's time (pose, physics, render, host copy) measured alone.

Usage (GPU machine, after benchmarks/gpu_build.sh):
    PYTHONPATH=python python3 benchmarks/bench_cart.py --json benchmarks/results/cart_<gpu>.json
On the development machine (lavapipe): --camera 160x120 --seconds 5.
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import torch

from cressim.twin import JointCommand, Sensor, SensorLoop, TwinConfig, load_scene
from cressim.twin.camera_images import DTYPES, PRODUCTS
from cressim.twin.cart import Cart
from cressim.twin_scene_file import CartArm
import dataclasses

from bench_twin import paced

PSM3 = CartArm("PSM3", "psm", base_position=(0.04, 0.0, 0.30), base_rotation=(0.0, 0.0, -0.7071068, 0.7071068),
               initial_jp=(0.0, 0.0, 0.1, 0.0, 0.0, 0.0), home_jp=(0.0, 0.0, 0.11, 0.0, 0.0, 0.0))


def _ready(cart):
    for row in range(cart.num_envs):
        cart.state_command(row, "enable")
        cart.state_command(row, "home")
    cart.ecm.state_command(0, "enable")
    cart.ecm.state_command(0, "home")
    while any(arm.states[0].is_busy for arm in cart.psms) or cart.ecm.states[0].is_busy:
        cart.tick()


def _drive(cart, k):
    for row in range(cart.num_envs):  # each PSM's yaw on a sine (a servo_jp per arm, as clients send)
        cart.servo_jp(row, JointCommand(position=[0.2 * np.sin(0.05 * k + row), 0.0, 0.11, 0.0, 0.0, 0.0]))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--camera", default="640x480", help="WxH of each eye")
    ap.add_argument("--camera-rate", type=float, default=30.0)
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--json")
    args = ap.parse_args()
    torch.set_num_threads(1)
    width, height = map(int, args.camera.split("x"))
    scene = load_scene("patient_cart.yaml")
    scene = dataclasses.replace(scene, cart=scene.cart + (PSM3,))
    t0 = time.perf_counter()
    cart = Cart(TwinConfig(scene=scene, camera_width=width, camera_height=height))
    row = {"psms": cart.num_envs, "eyes": 2, "camera": f"{width}x{height}", "camera_rate": args.camera_rate,
           "build_s": time.perf_counter() - t0, "device": cart.engine.device["name"]}
    _ready(cart)
    n = 200
    t = time.perf_counter()
    for k in range(n):
        _drive(cart, k)
        cart.tick()
        cart.snapshot()
    row["unpaced_tick_ms"] = (time.perf_counter() - t) / n * 1e3

    # as the node: one readback of every product of both eyes, converted into arrays kept from frame
    # to frame (the node's are its messages' data)
    out = {p: [np.empty((height, width, 3) if p == "color" else (height, width), DTYPES[p]) for _ in range(2)]
           for p in PRODUCTS}
    sensors = SensorLoop(cart, [Sensor("camera", args.camera_rate, render=True,
                                       read=lambda: cart._images.grab(PRODUCTS),
                                       publish=lambda raw, stamp: cart._images.convert(raw, out))])
    sensors.render_now()  # pipelines built before timing
    frames = []
    for _ in range(10):  # one stereo frame alone: pose, physics, render, host copy and conversion
        a = time.perf_counter()
        with cart.engine_lock:
            cart.step_engine(render=True)
            raw = cart._images.grab(PRODUCTS)
        cart._images.convert(raw, out)
        frames.append(time.perf_counter() - a)
    row["stereo_frame_ms"] = float(np.median(frames)) * 1e3
    row.update(paced(cart, sensors, _drive, args.seconds, "stereo"))
    print(f"cart: ECM + {row['psms']} PSMs, stereo {row['camera']} at {args.camera_rate:g} Hz on {row['device']}: "
          f"unpaced tick {row['unpaced_tick_ms']:.2f} ms; paced {row['paced_ticks_per_s']:.1f} ticks/s, tick "
          f"{row['paced_tick_mean_ms']:.2f} ms (max {row['paced_tick_max_ms']:.1f}); stereo "
          f"{row['stereo_frames_per_s']:.1f} frames/s ({row['stereo_frames_skipped']} skipped), one stereo frame "
          f"{row['stereo_frame_ms']:.1f} ms; built in {row['build_s']:.1f} s", flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps([row], indent=2))


if __name__ == "__main__":
    main()
