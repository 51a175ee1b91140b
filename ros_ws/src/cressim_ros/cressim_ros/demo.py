"""The main demo: the dVRK PSM twin on the tissue retraction scene, headless, driven by a
dVRK-style client over ROS 2 (DDS on loopback): the client opens the jaws over the flap's free
edge, closes them on it, lifts it 20 mm, holds it while reading the force on the tool
(spatial/measured_cf), and lets go. The twin records an MCAP dataset (arm topics, wrench, tf,
camera images) that is read back with the mcap reader, summarised, and images from it saved as
PNG (the flap flat, lifted, and back).

Needs the ROS 2 environment (`source ros_ws/env.sh`; `make demo` does it):

    python -m cressim_ros.demo [--seconds 1] [--out out/demo] [--bag bags/demo]

The twin runs scenes/psm_retraction.yaml (a 640x480 camera at 30 Hz); on a CPU (lavapipe) the
camera renders fewer frames than its rate (frames are skipped) while the arm keeps its 100 Hz.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import time
from pathlib import Path

import numpy as np

SCENE = "psm_retraction.yaml"
EDGE = np.array([0.0, -0.0175, 0.1545])  # m, world: the flap's free edge, mid-thickness (tissue_retraction.yaml)
JAW_MIDDLE = 0.006  # m from the tool tip (the jaws' pivot) along the jaws: where they grasp
RCM = np.array([0.0, 0.0, 0.3])  # the arm's base (measured_cp frame) in the world
LIFT = 0.02  # m


def run(out_dir: str = "out/demo", seconds: float = 1.0, bag_dir: str = "bags/demo") -> int:
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
    twin = Twin(domain, out / "twin.log", f"scene:={SCENE}", f"record:={bag}")
    ral = None
    try:
        startup = twin.wait_ready()
        ral = Ral("cressim_demo_client", domain)
        arm = Arm(ral, "/PSM1")
        ral.check_connections(timeout=60)
        # the twin is ready (its first tick published): enable and home answer within ticks
        assert arm.enable(30) and arm.home(30), f"enable/home failed: {arm.operating_state()}"
        T = arm.measured_cp()  # jaws pointing down at home; keep the orientation

        def tip_at(height):  # the tool tip where the jaws' middle is `height` above the edge
            goal = T.copy()
            goal[:3, 3] = EDGE + [0.0, 0.0, height + JAW_MIDDLE] - RCM
            assert arm.move_cp(goal).wait(20), f"move_cp to {goal[:3, 3]} did not finish"

        assert arm.jaw.move_jp(np.array([0.8])).wait(10), "jaw open"
        tip_at(0.02)
        tip_at(0.0)
        rest = arm.measured_cp()[2, 3]
        moments = {"flat": ral.now()}
        assert arm.jaw.move_jp(np.array([-0.2])).wait(10), "jaw close"
        tip_at(LIFT)
        time.sleep(seconds)  # hold: the flap hangs from the jaws
        lifted = arm.measured_cp()[2, 3] - rest
        force = arm.spatial_measured_cf()
        moments["lifted"] = ral.now()
        assert arm.jaw.move_jp(np.array([0.8])).wait(10), "jaw open"
        tip_at(0.04)
        time.sleep(seconds)  # the flap falls back
        moments["released"] = ral.now()
        rate = arm.measured_js_rate()
    finally:
        if ral is not None:
            ral.shutdown()
        code = twin.stop()
    info = bag_info(bag)
    images = save_images(bag, out / "images", moments)
    summary = {"twin_startup_s": startup, "exit_code": code, "measured_js_hz": rate, "lift_m": lifted,
               "force_on_tool_n": force[:3].tolist(), "bag": str(bag), "bag_info": info,
               "images": [str(p) for p in images]}
    (out / "twin_summary.json").write_text(json.dumps(summary, indent=2, default=str))
    print(f"twin: ready in {startup:.1f} s; measured_js at {rate:.0f} Hz; the jaws lifted the flap {lifted * 1e3:.1f} mm "
          f"and felt {np.round(force[:3], 3).tolist()} N; exit code {code}")
    print(format_info(info))
    print(f"images from the recording: {', '.join(str(p) for p in images)}")
    return 0 if code == 0 and images else 1


def save_images(bag: Path, folder: Path, moments: dict[str, float]) -> list[Path]:
    """PNGs of the recorded frames nearest each moment (name -> ROS time, s) of each image topic:
    colour, depth (colour-mapped, no return black), segmentation (a colour per label) and
    ultrasound, decoded from the MCAP."""
    from cressim.io import colour_depth, colour_segmentation, save_png
    from cressim.record.reader import read_messages

    topics = {"color": "/camera/color/image_raw", "depth": "/camera/depth/image_raw",
              "segmentation": "/camera/segmentation/image_raw", "ultrasound": "/ultrasound/image_raw"}
    written = []
    for product, topic in topics.items():
        msgs = [m for _, m in read_messages(bag, topic, decode=True)]
        if not msgs:
            continue
        stamps = np.array([m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec for m in msgs])
        for name, t in moments.items():
            m = msgs[int(np.argmin(np.abs(stamps - t)))]
            data = np.asarray(m.data, dtype=np.uint8)
            if product == "color":
                img = data.reshape(m.height, m.width, 3)
            elif product == "ultrasound":
                img = data.reshape(m.height, m.width)
            elif product == "depth":
                img = colour_depth(np.nan_to_num(data.view(np.float32).reshape(m.height, m.width)))
            else:
                img = colour_segmentation(data.view(np.uint16).reshape(m.height, m.width))
            written.append(save_png(folder / f"{product}_{name}.png", img))
    return written


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m cressim_ros.demo", description=__doc__.split("\n\n")[0])
    p.add_argument("--seconds", type=float, default=1.0, help="how long the flap is held up, and left after")
    p.add_argument("--out", default="out/demo", help="folder for the images and the summary")
    p.add_argument("--bag", default="bags/demo", help="the recording (replaced each run)")
    args = p.parse_args(argv)
    return run(out_dir=args.out, seconds=args.seconds, bag_dir=args.bag)


if __name__ == "__main__":
    raise SystemExit(main())
