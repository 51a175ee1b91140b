"""Where a PPO update's time goes: the rollout (env steps + policy) against the learning phase,
per env count, and the top CUDA kernels of one update under torch.profiler.

    PYTHONPATH=python python3 benchmarks/profile_ppo.py TargetCenter --envs 32,256 --json out.json
"""
from __future__ import annotations

import argparse
import json
import time

import torch

from cressim.learn.bench import _make
from cressim.learn.config import ppo_config
from cressim.learn.learner import make_learner
from cressim.learn.rollout import collect_rollout, sync
from cressim.learn.vec_env import CressimVecEnv


def timed_update(venv, alg, steps: int) -> tuple[float, float]:
    """(rollout seconds, learning seconds) of one update, the device drained between them."""
    t0 = time.perf_counter()
    collect_rollout(venv, alg, steps)
    sync(venv.device)
    t1 = time.perf_counter()
    alg.update()
    sync(venv.device)
    return t1 - t0, time.perf_counter() - t1


def profile(task: str, n: int, updates: int, trace: bool) -> dict:
    env = _make(task, n, None)
    venv = CressimVecEnv(env)
    cfg = ppo_config(task)
    alg, backend = make_learner(venv, cfg, "torch")
    for _ in range(2):
        timed_update(venv, alg, cfg.rollout)
    times = [timed_update(venv, alg, cfg.rollout) for _ in range(updates)]
    roll = sum(t[0] for t in times) / updates
    learn = sum(t[1] for t in times) / updates
    row = {"envs": n, "rollout_s": roll, "learn_s": learn, "ppo_sps": n * cfg.rollout / (roll + learn),
           "minibatches": cfg.num_mini_batches(n) * cfg.epochs}
    print(f"{task} {n} envs: rollout {roll * 1e3:.1f} ms, learning {learn * 1e3:.1f} ms "
          f"({row['minibatches']} minibatches, {learn / row['minibatches'] * 1e3:.2f} ms each), "
          f"{row['ppo_sps']:,.0f} env-steps/s", flush=True)
    if trace and env.device.type == "cuda":
        from torch.profiler import ProfilerActivity, profile as prof

        with prof(activities=[ProfilerActivity.CPU, ProfilerActivity.CUDA]) as p:
            timed_update(venv, alg, cfg.rollout)
        table = p.key_averages().table(sort_by="cuda_time_total", row_limit=25)
        print(table)
        row["profile"] = table
    env.close()
    return row


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("task", nargs="?", default="TargetCenter")
    ap.add_argument("--envs", default="32,256")
    ap.add_argument("--updates", type=int, default=3)
    ap.add_argument("--trace", action="store_true", help="torch.profiler table of one update per count")
    ap.add_argument("--json")
    args = ap.parse_args()
    rows = [profile(args.task, int(n), args.updates, args.trace) for n in args.envs.split(",")]
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"task": args.task, "torch": torch.__version__, "rows": rows}, f, indent=1)


if __name__ == "__main__":
    main()
