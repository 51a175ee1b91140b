"""The main demo: the dVRK PSM twin, headless, driven by a dVRK-style client over ROS 2 (DDS on
loopback), recording a short MCAP dataset that is then read back and summarised.

Needs the ROS 2 environment (`source ros_ws/env.sh`; `make demo` does it). Camera images join
the recording when the renderer lands; this demo records the arm's topics.
"""
from __future__ import annotations

import json
import math
import os
import shutil
import time
from pathlib import Path

import numpy as np

PERIOD = 0.01  # the client's servo period (100 Hz)


def run(out_dir: str = "out/demo", seconds: float = 2.0) -> int:
    from cressim_ros.dvrk_client import Arm, Ral
    from cressim_ros.twin_process import Twin

    from cressim.record.reader import bag_info, format_info

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    bag = out / "twin_bag"
    shutil.rmtree(bag, ignore_errors=True)
    domain = 1 + os.getpid() % 100
    twin = Twin(domain, out / "twin.log", f"record:={bag}")
    ral = None
    try:
        startup = twin.wait_ready()
        ral = Ral("cressim_demo_client", domain)
        arm = Arm(ral, "/PSM1")
        ral.check_connections(timeout=20)
        assert arm.enable(5) and arm.home(10), f"enable/home failed: {arm.operating_state()}"
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
    summary = {"twin_startup_s": startup, "exit_code": code, "measured_js_hz": rate,
               "servo_tracking_max_rad": worst, "bag": str(bag), "bag_info": info}
    (out / "twin_summary.json").write_text(json.dumps(summary, indent=2, default=str))
    print(f"twin: ready in {startup:.1f} s; measured_js at {rate:.0f} Hz; servo_jp tracked within {worst:.4f} rad; "
          f"exit code {code}")
    print(format_info(info))
    return 0 if code == 0 else 1
