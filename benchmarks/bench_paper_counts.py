"""Each batched task at the paper's own env count (its peak, TASKS.md) against the throughput the
speed issue asks for, with where the step's GPU time goes (every compute pass timed).

    PYTHONPATH=python python3 benchmarks/bench_paper_counts.py [--tasks A,B] [--json OUT]

Step throughput is `cressim bench`'s step protocol (64 warm-up and 256 measured steps, a sync
after each), both ways it reports: zero actions written in place once (the simulator alone, the
paper's step-only figure and the speed issue's targets) and actions copied in by a CUDA kernel
every step (what a torch policy between steps adds: the CUDA-to-Vulkan hand-off); the breakdown
is profile_task.py --passes (its own steps, with timestamps after every pass, which cost a
little themselves).
"""
from __future__ import annotations

import argparse
import json
import platform
import time
from pathlib import Path

import torch

from cressim.learn.bench import REFERENCE, bench_step

from profile_task import profile

# (env count, the paper's figure there, the target): TASKS.md and the speed issue
COUNTS = {
    "SoftBodyPush": (512, 88_580),
    "FluidPour": (128, 60_020),
    "TissueRetract": (256, 83_550),
    "BloodSuction": (128, 8_310),
    "TargetCenter": (32, 175_000),
    "UltrasoundScan": (32, 50_000),
}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tasks", default=",".join(COUNTS))
    parser.add_argument("--device", default=None)
    parser.add_argument("--json")
    args = parser.parse_args()
    rows = []
    for task in args.tasks.split(","):
        envs, target = COUNTS[task]
        step = bench_step(task, envs, args.device)
        breakdown = profile(task, envs, warmup=32, steps=64, passes=True)
        paper = REFERENCE[task]["paper RTX 4090 step"][envs]
        sps = step["step_inplace_sps"]
        rows.append({"task": task, "envs": envs, "step_inplace_sps": sps, "step_copied_sps": step["step_sps"],
                     "paper": paper, "target": target, "x_paper": sps / paper, "meets_target": sps >= target,
                     "gpu_ms": breakdown["gpu_ms"], "gpu_ms_total": breakdown["gpu_ms_total"],
                     "wall_ms_per_step": breakdown["wall_ms_per_step"], "passes": breakdown["passes"][:20],
                     "device": step["vulkan_device"]})
        r = rows[-1]
        print(f"{task:15s} {envs:5d} envs {sps:>12,.0f} env-steps/s in place ({r['step_copied_sps']:,.0f} copied)  "
              f"paper {paper:>8,}  "
              f"x{r['x_paper']:5.1f}  target {target:>8,} {'met' if r['meets_target'] else 'NOT met'}  "
              f"GPU {r['gpu_ms_total']:.3f} ms of {r['wall_ms_per_step']:.3f} ms a step")
        for p in r["passes"][:6]:
            print(f"      {p['op']:24.24s} {p['pass']:40.40s} {p['ms']:7.3f} ms x{p['dispatches']:g}")
    if args.json:
        Path(args.json).write_text(json.dumps({"command": "benchmarks/bench_paper_counts.py", "time": time.strftime(
            "%Y-%m-%dT%H:%M:%S"), "torch": torch.__version__, "python": platform.python_version(), "rows": rows},
            indent=1))


if __name__ == "__main__":
    main()
