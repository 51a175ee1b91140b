"""Throughput of a batched task, as TASKS.md's protocol: pure stepping (zero actions, 64
warm-up and 256 measured steps, a device sync after every step) and PPO (5 warm-up and 10
measured updates of 128 steps; env steps counted, wall time includes learning). Each
(env count, mode) runs in a fresh env, the previous one freed first."""
from __future__ import annotations

import gc
import json
import platform
import re
import sys
import time
from pathlib import Path

import torch

from .config import ppo_config
from .learner import make_learner
from .plot import plot_throughput
from .rollout import resolve_device, run_update, sync
from .vec_env import CressimVecEnv

PAPER_SWEEP = (1, 8, 16, 32, 64, 128, 256, 512, 1024, 2048, 4096, 8192)
# TASKS.md's sweeps where they differ from CartPole's
TASK_SWEEPS = {"UltrasoundScan": (1, 8, 32, 64), "BloodSuction": (1, 8, 16, 32, 64, 128, 256)}
# The paper's figures (TASKS.md, RTX 4090, Vulkan) and MJX on an H100 as the peer, env-steps/s.
REFERENCE = {
    "CartPole": {
        "paper RTX 4090 step": {1: 627, 1024: 405_529, 4096: 1_249_689, 8192: 2_030_481},
        "paper RTX 4090 PPO": {1: 555, 1024: 236_791, 4096: 402_104, 8192: 451_904},
        "MJX H100 step": {1024: 505_730, 4096: 2_001_270, 8192: 2_823_936, 65536: 17_915_751},
    },
    "UltrasoundScan": {
        "paper RTX 4090 step": {1: 71.6, 8: 305, 32: 420, 64: 386},
        "paper RTX 4090 PPO": {32: 306},
    },
    "TargetCenter": {  # 64x64 RGB; Isaac Lab's Cartpole-RGB (about 50k at 1024 envs) as the brief gives it
        "paper RTX 4090 step": {32: 35_064, 256: 21_816},
        "paper RTX 4090 PPO": {32: 14_493},
        "Isaac Lab Cartpole-RGB step": {1024: 50_000},
    },
    "SoftBodyPush": {
        "paper RTX 4090 step": {128: 5_967, 256: 7_501, 512: 8_858, 1024: 7_024},
        "paper RTX 4090 PPO": {512: 8_486},
    },
    "TissueRetract": {
        "paper RTX 4090 step": {128: 5_626, 256: 8_355},
        "paper RTX 4090 PPO": {256: 7_809},
    },
    "BloodSuction": {
        "paper RTX 4090 step": {128: 831, 256: 826},
        "paper RTX 4090 PPO": {128: 819},
    },
    "FluidPour": {
        "paper RTX 4090 step": {64: 5_417, 128: 6_002, 256: 4_544},
        "paper RTX 4090 PPO": {128: 5_168},
    },
}


def engine_bytes(env) -> int | None:
    """Bytes of the engine's buffers (internal and shared): what the engine can tell about its
    device memory; driver overhead, pipelines and torch's own memory are not in it."""
    e = env.engine
    try:
        return sum(e.buffer(k).nbytes for k in (*e.internal_keys, *e.shared_buffers))
    except (AttributeError, TypeError):
        return None


def _make(task, num_envs, device, seed=0):
    from cressim import envs

    gc.collect()  # the previous count's env (and its Vulkan memory) goes before the next is built
    # the paper's step: no final observation (its learners never read it; image tasks would render twice)
    return envs.make(task, num_envs=num_envs, device=resolve_device(device), seed=seed, final_observation=False)


def bench_step(task: str, num_envs: int, device=None, warmup: int = 64, steps: int = 256) -> dict:
    t0 = time.perf_counter()
    env = _make(task, num_envs, device)
    setup = time.perf_counter() - t0
    env.reset()
    # zero actions written once, in place: a copy into env.actions every step would be a CUDA
    # kernel between two Vulkan frames, about 0.35 ms of context switch on the NVIDIA driver
    # (benchmarks/README.md), which is the learner's cost, not the simulator's
    zeros = env.actions
    zeros.zero_()
    for _ in range(warmup):
        env.step(zeros)
        sync(env.device)
    t0 = time.perf_counter()
    for _ in range(steps):
        env.step(zeros)  # returns once the frame's GPU work is done
        sync(env.device)
    dt = time.perf_counter() - t0
    out = {"step_sps": steps * num_envs / dt, "engine_bytes": engine_bytes(env), "setup_s": setup,
           "particles_per_env": getattr(env, "particles_per_env", None),
           "vulkan_device": env.engine.device["name"], "torch_device": str(env.device)}
    if hasattr(env, "scatterers"):  # ultrasound tasks: the workload's size
        out["scatterers"] = env.scatterers
        out["scatterers_per_env"] = env.scatterers / num_envs
    env.close()
    del env, zeros
    gc.collect()
    return out


def bench_ppo(task: str, num_envs: int, device=None, warmup: int = 5, updates: int = 10, rollout: int = 128,
              backend: str = "auto", seed: int = 0, minibatch: int | None = None) -> dict:
    torch.manual_seed(seed)
    env = _make(task, num_envs, device, seed)
    venv = CressimVecEnv(env)
    alg, backend = make_learner(venv, ppo_config(task, rollout=rollout, minibatch=minibatch), backend)
    for _ in range(warmup):
        run_update(venv, alg, rollout)
    sync(env.device)
    t0 = time.perf_counter()
    for _ in range(updates):
        run_update(venv, alg, rollout)
    sync(env.device)
    dt = time.perf_counter() - t0
    out = {"ppo_sps": updates * rollout * num_envs / dt, "ppo_backend": backend, "engine_bytes": engine_bytes(env),
           "vulkan_device": env.engine.device["name"], "torch_device": str(env.device)}
    env.close()
    del env, venv, alg
    gc.collect()
    return out


def _slug(text: str) -> str:
    return re.sub(r"[^a-z0-9]+", "-", text.lower()).strip("-")[:40]


def _num(x) -> str:
    return "-" if x is None else f"{x:,.0f}"


def run(task: str = "CartPole", env_counts=None, mode: str = "both", out_dir="benchmarks/results",
        device=None, backend: str = "auto", extend: bool = False, protocol: dict | None = None,
        minibatch: int | None = None) -> dict:
    """Measures each env count; with `extend`, keeps doubling past the last count while step
    throughput still rises by 5 % or more. Prints a table; writes JSON and a PNG."""
    p = {"warmup_steps": 64, "steps": 256, "warmup_updates": 5, "updates": 10, "rollout": 128, **(protocol or {})}
    rows, counts = [], list(env_counts or TASK_SWEEPS.get(task, PAPER_SWEEP))
    while counts:
        n = counts.pop(0)
        row = {"envs": n}
        if mode in ("step", "both"):
            row.update(bench_step(task, n, device, p["warmup_steps"], p["steps"]))
        if mode in ("ppo", "both"):
            row.update(bench_ppo(task, n, device, p["warmup_updates"], p["updates"], p["rollout"], backend,
                                 minibatch=minibatch))
            row["ppo_minibatch"] = minibatch or ppo_config(task).minibatch
        row["engine_bytes_per_env"] = row["engine_bytes"] / n if row.get("engine_bytes") else None
        rows.append(row)
        print(f"  {n} envs: " + ", ".join(f"{k} {_num(row[k])}" for k in ("step_sps", "ppo_sps") if k in row)
              + (f", {row['scatterers'] // n:,} scatterers per env" if "scatterers" in row else ""), flush=True)
        if extend and not counts and mode != "ppo" and (len(rows) < 2 or row["step_sps"] >= 1.05 * rows[-2]["step_sps"]):
            counts.append(2 * n)

    ref = REFERENCE.get(task, {})
    name = rows[0]["vulkan_device"] if rows else "?"
    backends = sorted({r["ppo_backend"] for r in rows if "ppo_backend" in r})
    print(f"\n{task} on {name} ({rows[0]['torch_device'] if rows else '?'})"
          + (f", PPO learner: {', '.join(backends)}" if backends else ""))
    head = f"{'envs':>7} {'step env-steps/s':>17} {'ppo env-steps/s':>16} {'engine KiB/env':>15}"
    ref_cols = [k for k in ref if k.startswith("paper")]
    print(head + "".join(f" {k.replace('paper RTX 4090', '4090'):>12}" for k in ref_cols))
    for r in rows:
        mem = "n/a" if r["engine_bytes_per_env"] is None else f"{r['engine_bytes_per_env'] / 1024:.2f}"
        print(f"{r['envs']:>7} {_num(r.get('step_sps')):>17} {_num(r.get('ppo_sps')):>16} {mem:>15}"
              + "".join(f" {_num(ref[k].get(r['envs'])):>12}" for k in ref_cols))

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    stem = f"{task.lower()}_{_slug(name)}"
    result = {
        "task": task, "device_name": name, "torch_device": rows[0]["torch_device"] if rows else None,
        "env_counts": [r["envs"] for r in rows], "mode": mode, "ppo_backend": backends,
        "command": " ".join(sys.argv), "protocol": p, "ppo": ppo_config(task, rollout=p["rollout"]).to_dict(),
        "torch": torch.__version__, "python": platform.python_version(), "time": time.strftime("%Y-%m-%dT%H:%M:%S"),
        "memory_note": "engine_bytes: sum of the engine's buffer sizes (internal + shared) on the Vulkan device; "
                       "excludes driver overhead and torch allocations",
        "results": rows, "reference": {k: {str(n): v for n, v in s.items()} for k, s in ref.items()},
        "reference_note": "paper: TASKS.md (RTX 4090, Vulkan); MJX: H100, step-only, figures as given in the brief",
    }
    (out / f"{stem}.json").write_text(json.dumps(result, indent=1))
    series = {}
    for key, label in (("step_sps", "ours step"), ("ppo_sps", "ours PPO")):
        series[f"{label} ({name})"] = {r["envs"]: r[key] for r in rows if key in r}
    series.update(ref)
    plot_throughput(series, out / f"{stem}.png", f"{task} throughput")
    print(f"wrote {out / stem}.json and .png")
    return result
