"""Weak scaling of PPO over GPUs: `cressim train TASK --nproc P` with a fixed env count per GPU.

For each process count P the same per-GPU load (--envs-per-gpu) trains for --iterations updates
under torchrun (one process and engine a GPU, NCCL); the first --warmup updates (CUDA graph
capture, allocator growth) are left out. Reported per P, as medians over the measured updates:
env-steps/s of the rollouts alone (the policy in the loop, all GPUs together), PPO env-steps/s
end to end (rollout and update), and the weak-scaling efficiency, throughput(P) / (P x
throughput(1)). Output: a table and RESULTS/distributed_<task>_<device>.json.

    python3 benchmarks/bench_distributed.py CartPole --envs-per-gpu 8192 --nproc 1,2,4
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import torch


def run(task: str, nproc: int, envs: int, iterations: int, extra: list[str]) -> dict:
    out = Path(tempfile.mkdtemp(prefix=f"dist_{task}_{nproc}_"))
    command = [sys.executable, "-m", "cressim", "train", task, "--envs", str(envs * nproc), "--iterations",
               str(iterations), "--backend", "torch", "--device", "cuda", "--save-every", str(iterations),
               "--out", str(out), "--nproc", str(nproc), *extra]
    r = subprocess.run(command, capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"{' '.join(command)} failed:\n{r.stdout[-2000:]}\n{r.stderr[-4000:]}")
    return json.loads((out / "metrics.json").read_text()) | {"command": " ".join(command)}


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("task", nargs="?", default="CartPole")
    p.add_argument("--envs-per-gpu", type=int, default=8192)
    p.add_argument("--nproc", default="1,2,4", help="comma-separated process (GPU) counts")
    p.add_argument("--iterations", type=int, default=30)
    p.add_argument("--warmup", type=int, default=5)
    p.add_argument("--out", default="benchmarks/results")
    a, extra = p.parse_known_args()  # the rest: more `cressim train` arguments
    device = torch.cuda.get_device_name(0)
    rows = []
    for n in (int(x) for x in a.nproc.split(",")):
        if n > torch.cuda.device_count():
            print(f"skipping {n} processes: {torch.cuda.device_count()} GPUs here")
            continue
        m = run(a.task, n, a.envs_per_gpu, a.iterations, extra)
        measured = m["history"][a.warmup:]
        rows.append({"gpus": n, "envs": a.envs_per_gpu * n, "command": m["command"],
                     "rollout_steps_per_s": statistics.median(h["rollout_steps_per_s"] for h in measured),
                     "ppo_steps_per_s": statistics.median(h["steps_per_s"] for h in measured),
                     "mean_return_last": m["history"][-1]["mean_return"]})
    base = rows[0] if rows and rows[0]["gpus"] == 1 else None
    print(f"{a.task}, {a.envs_per_gpu} envs per GPU, {device}, PPO (built-in learner, CUDA graphs, NCCL)")
    print(f"{'GPUs':>4} {'envs':>7} {'rollout steps/s':>16} {'eff':>6} {'PPO steps/s':>13} {'eff':>6}")
    for r in rows:
        for key in ("rollout", "ppo"):
            r[f"{key}_efficiency"] = r[f"{key}_steps_per_s"] / (r["gpus"] * base[f"{key}_steps_per_s"]) if base else None
        print(f"{r['gpus']:>4} {r['envs']:>7} {r['rollout_steps_per_s']:>16,.0f} {r['rollout_efficiency'] or 0:>6.2f} "
              f"{r['ppo_steps_per_s']:>13,.0f} {r['ppo_efficiency'] or 0:>6.2f}")
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    slug = device.lower().replace("nvidia ", "nvidia-").split()[0]
    path = out / f"distributed_{a.task.lower()}_{slug}.json"
    path.write_text(json.dumps({"task": a.task, "device": device, "envs_per_gpu": a.envs_per_gpu,
                                "iterations": a.iterations, "warmup": a.warmup, "environment":
                                {k: os.environ.get(k) for k in ("NCCL_NVLS_ENABLE",)}, "rows": rows}, indent=1))
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
