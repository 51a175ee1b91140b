"""The main demo: the dVRK PSM twin, headless, driven by a dVRK-style client over ROS 2 (DDS on
loopback), recording a short MCAP dataset (arm topics, tf, camera and ultrasound images) that is
then read back with the mcap reader, summarised, and a few of its images saved as PNG.

Needs the ROS 2 environment (`source ros_ws/env.sh`; `make demo` does it):

    python -m cressim_ros.demo [--seconds 2] [--out out/demo] [--bag bags/demo]

The twin runs the default scene (640x480 camera at 30 Hz) with the ultrasound probe on; on a
CPU (lavapipe) the camera renders fewer frames than its rate (frames are skipped) while the arm
keeps its 100 Hz.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import time
from pathlib import Path

import numpy as np

PERIOD = 0.01  # the client's servo period (100 Hz)


def run(out_dir: str = "out/demo", seconds: float = 2.0, bag_dir: str = "bags/demo") -> int:
    """Drives the twin for a few seconds; the recording goes to bag_dir (replaced each run),
    images and the summary to out_dir."""
    from cressim_ros.dvrk_client import Arm, Ral
    from cressim_ros.twin_process import Twin

    from cressim.record.reader import bag_info, format_info

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    bag = Path(bag_dir).resolve()  # the twin runs in the repository root
    bag.parent.mkdir(parents=True, exist_ok=True)
    shutil.rmtree(bag, ignore_errors=True)
    domain = 1 + os.getpid() % 100
    sensors = "[joints, cartesian, velocity, wrench, jacobian, tf, clock, color, depth, segmentation, ultrasound]"
    twin = Twin(domain, out / "twin.log", f"record:={bag}", f"sensors:={sensors}")
    ral = None
    try:
        startup = twin.wait_ready()
        ral = Ral("cressim_demo_client", domain)
        arm = Arm(ral, "/PSM1")
        ral.check_connections(timeout=60)
        # the twin is ready (its first tick published): enable and home answer within ticks
        assert arm.enable(30) and arm.home(30), f"enable/home failed: {arm.operating_state()}"
        goal = np.array([0.2, -0.15, 0.12, 0.3, 0.2, -0.2])
        assert arm.move_jp(goal).wait(10), "move_jp did not finish"
        worst = 0.0
        for k in range(int(seconds / PERIOD)):  # servo_jp sine on yaw and wrist yaw
            q = goal.copy()
            q[0] += 0.1 * math.sin(math.pi * k * PERIOD)
            q[5] += 0.3 * math.sin(2 * math.pi * k * PERIOD)
            arm.servo_jp(q)
            if k > 10:
                worst = max(worst, float(np.abs(arm.measured_jp() - q).max()))
            time.sleep(PERIOD)
        assert arm.jaw.move_jp(np.array([0.8])).wait(5) and arm.jaw.move_jp(np.array([0.0])).wait(5), "jaw"
        rate = arm.measured_js_rate()
    finally:
        if ral is not None:
            ral.shutdown()
        code = twin.stop()
    info = bag_info(bag)
    images = save_images(bag, out / "images")
    summary = {"twin_startup_s": startup, "exit_code": code, "measured_js_hz": rate,
               "servo_tracking_max_rad": worst, "bag": str(bag), "bag_info": info,
               "images": [str(p) for p in images]}
    (out / "twin_summary.json").write_text(json.dumps(summary, indent=2, default=str))
    print(f"twin: ready in {startup:.1f} s; measured_js at {rate:.0f} Hz; servo_jp tracked within {worst:.4f} rad; "
          f"exit code {code}")
    print(format_info(info))
    print(f"images from the recording: {', '.join(str(p) for p in images)}")
    return 0 if code == 0 and images else 1


def save_images(bag: Path, folder: Path) -> list[Path]:
    """PNGs of the first, middle and last recorded frames of each image topic: colour, depth
    (colour-mapped, no return black), segmentation (a colour per label) and ultrasound, decoded
    from the MCAP."""
    from cressim.io import colour_depth, colour_segmentation, save_png
    from cressim.record.reader import read_messages

    topics = {"color": "/camera/color/image_raw", "depth": "/camera/depth/image_raw",
              "segmentation": "/camera/segmentation/image_raw", "ultrasound": "/ultrasound/image_raw"}
    written = []
    for product, topic in topics.items():
        msgs = [m for _, m in read_messages(bag, topic, decode=True)]
        for k in sorted({0, len(msgs) // 2, len(msgs) - 1}) if msgs else ():
            m = msgs[k]
            data = np.asarray(m.data, dtype=np.uint8)
            if product == "color":
                img = data.reshape(m.height, m.width, 3)
            elif product == "ultrasound":
                img = data.reshape(m.height, m.width)
            elif product == "depth":
                img = colour_depth(np.nan_to_num(data.view(np.float32).reshape(m.height, m.width)))
            else:
                img = colour_segmentation(data.view(np.uint16).reshape(m.height, m.width))
            written.append(save_png(folder / f"{product}_{k:03d}.png", img))
    return written


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m cressim_ros.demo", description=__doc__.split("\n\n")[0])
    p.add_argument("--seconds", type=float, default=2.0, help="length of the servo_jp sine")
    p.add_argument("--out", default="out/demo", help="folder for the images and the summary")
    p.add_argument("--bag", default="bags/demo", help="the recording (replaced each run)")
    args = p.parse_args(argv)
    return run(out_dir=args.out, seconds=args.seconds, bag_dir=args.bag)


if __name__ == "__main__":
    raise SystemExit(main())
