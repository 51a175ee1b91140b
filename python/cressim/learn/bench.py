"""Throughput of a batched task, as TASKS.md's protocol: pure stepping (zero actions, 64
warm-up and 256 measured steps, a device sync after every step; the actions copied each step and
written in place), a rollout with the PPO actor in the loop (in torch, and as an engine pass),
and PPO (5 warm-up and 10 measured updates of 128 steps; env steps counted, wall time includes
learning). Each (env count, mode) runs in a fresh env, the previous one freed first; MEASURED
says what each number is, and the JSON carries it."""
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
from .device import resolve_device, sync
from .engine_rollout import EngineRollout
from .learner import make_learner
from .plot import plot_throughput
from .rollout import collect_rollout
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
    """Zero actions copied into the env each step, as a learner's actions are (`step_sps`: on
    CUDA a kernel between two Vulkan frames, whose hand-off costs more than CartPole's frame),
    and written once in place with no CUDA work between frames (`step_inplace_sps`: the
    simulator alone)."""
    t0 = time.perf_counter()
    env = _make(task, num_envs, device)
    setup = time.perf_counter() - t0
    env.reset()
    out = {"setup_s": setup}
    zeros = torch.zeros_like(env.actions)
    for key, actions in (("step_sps", zeros), ("step_inplace_sps", env.actions)):
        env.actions.zero_()
        for _ in range(warmup):
            env.step(actions)
            sync(env.device)
        t0 = time.perf_counter()
        for _ in range(steps):
            env.step(actions)  # returns once the frame's GPU work is done
            sync(env.device)
        out[key] = steps * num_envs / (time.perf_counter() - t0)
    out.update({"engine_bytes": engine_bytes(env), "particles_per_env": getattr(env, "particles_per_env", None),
                "vulkan_device": env.engine.device["name"], "torch_device": str(env.device)})
    if hasattr(env, "scatterers"):  # ultrasound tasks: the workload's size
        out["scatterers"] = env.scatterers
        out["scatterers_per_env"] = env.scatterers / num_envs
    env.close()
    del env, zeros
    gc.collect()
    return out


def engine_policy_fits(task: str, env) -> bool:
    """Whether the task's PPO actor can run in the engine over `env` (the task's): an MLP on flat
    float32 observations (engine_policy.py) or TASKS.md's CNN on uint8 or float32 images
    (engine_cnn.py)."""
    network, dtype = ppo_config(task).network, str(env.single_observation_space.dtype)
    return (network == "mlp" and dtype == "float32") or (network == "cnn" and dtype in ("uint8", "float32"))


def _learner(task, env, rollout, minibatch=None):
    venv = CressimVecEnv(env)
    alg, _ = make_learner(venv, ppo_config(task, rollout=rollout, minibatch=minibatch), "torch")
    return venv, alg


def bench_policy(task: str, num_envs: int, device=None, warmup: int = 128, steps: int = 256, rollout: int = 128,
                 seed: int = 0) -> dict:
    """A rollout with the PPO actor (TASKS.md's network for the task) in the loop, no learning:
    torch's policy step between frames (`policy_torch_sps`: the built-in learner's act, a CUDA
    graph, then env.step), and the actor as an engine pass with `rollout` steps per submit
    (`policy_engine_sps`, where the task's actor fits an engine pass: engine_policy_fits)."""
    torch.manual_seed(seed)
    env = _make(task, num_envs, device, seed)
    venv, alg = _learner(task, env, rollout)
    obs = venv.get_observations()

    def torch_step():
        nonlocal obs
        if alg.step == rollout:
            alg.step = 0
        actions = alg.act(obs)
        obs, rewards, dones, extras = venv.step(actions)
        alg.process_env_step(obs, rewards, dones, extras)

    with torch.inference_mode():
        for _ in range(warmup):
            torch_step()
        sync(env.device)
        t0 = time.perf_counter()
        for _ in range(steps):
            torch_step()
        sync(env.device)
    out = {"policy_torch_sps": steps * num_envs / (time.perf_counter() - t0),
           "vulkan_device": env.engine.device["name"], "torch_device": str(env.device)}
    in_engine = engine_policy_fits(task, env)
    env.close()
    del env, venv, alg
    if in_engine:
        torch.manual_seed(seed)
        env = _make(task, num_envs, device, seed)
        venv, alg = _learner(task, env, rollout)
        engine = EngineRollout(env, alg, seed=seed)
        for _ in range(max(1, warmup // rollout)):
            engine.record_steps(rollout)
            env.engine.end_frame()
        frames = max(1, steps // rollout)
        t0 = time.perf_counter()
        for _ in range(frames):
            engine.record_steps(rollout)
            env.engine.end_frame()  # returns once the frame's GPU work is done
        sync(env.device)
        out.update(policy_engine_sps=frames * rollout * num_envs / (time.perf_counter() - t0),
                   policy_steps_per_submit=rollout)
        env.close()
        del env, venv, alg, engine
    gc.collect()
    return out


def bench_ppo(task: str, num_envs: int, device=None, warmup: int = 5, updates: int = 10, rollout: int = 128,
              backend: str = "auto", seed: int = 0, minibatch: int | None = None, policy: str = "auto",
              compile: bool = False, fused_update: str = "auto") -> dict:
    """PPO end to end: rollouts and learning (`ppo_sps`); policy "engine" collects the rollouts
    with the actor in the engine (EngineRollout, the built-in learner), "torch" with the learner's
    policy step between frames, "auto" the engine where the task's actor fits it."""
    if policy not in ("auto", "engine", "torch"):
        raise ValueError(f"bench_ppo: policy must be 'auto', 'engine' or 'torch', got {policy!r}")
    torch.manual_seed(seed)
    env = _make(task, num_envs, device, seed)
    fits = backend in ("auto", "torch") and engine_policy_fits(task, env)
    in_engine = policy == "engine" or (policy == "auto" and fits)
    venv = CressimVecEnv(env)
    cfg = ppo_config(task, rollout=rollout, minibatch=minibatch, compile=compile or None, fused_update=fused_update)
    alg, backend = make_learner(venv, cfg, "torch" if in_engine or compile or fused_update == "on" else backend)
    collect = EngineRollout(env, alg, seed=seed).collect if in_engine else lambda: collect_rollout(venv, alg, rollout)
    for _ in range(warmup):
        collect()
        alg.update()
    sync(env.device)
    rollout_s = learn_s = 0.0
    for _ in range(updates):  # a sync between rollout and learning splits the time (costs little)
        t0 = time.perf_counter()
        collect()
        sync(env.device)
        t1 = time.perf_counter()
        alg.update()
        sync(env.device)
        rollout_s, learn_s = rollout_s + t1 - t0, learn_s + time.perf_counter() - t1
    samples = updates * rollout * num_envs
    out = {"ppo_sps": samples / (rollout_s + learn_s), "ppo_rollout_sps": samples / rollout_s,
           "ppo_learn_s_per_update": learn_s / updates, "ppo_backend": backend,
           "ppo_policy": "engine" if in_engine else "torch", "ppo_compiled": compile,
           "ppo_fused_update": getattr(alg, "fused", False), "engine_bytes": engine_bytes(env),
           "vulkan_device": env.engine.device["name"], "torch_device": str(env.device)}
    env.close()
    del env, venv, alg
    gc.collect()
    return out


def _slug(text: str) -> str:
    return re.sub(r"[^a-z0-9]+", "-", text.lower()).strip("-")[:40]


def _num(x) -> str:
    return "-" if x is None else f"{x:,.0f}"


MODES = {"step": ("step",), "policy": ("policy",), "ppo": ("ppo",), "both": ("step", "ppo"),
         "all": ("step", "policy", "ppo")}
# what each throughput key measured, written beside the numbers
MEASURED = {
    "step_sps": "env steps, zero actions copied into the env each step (a CUDA kernel between frames on CUDA)",
    "step_inplace_sps": "env steps, zero actions written once in place: no CUDA work between frames",
    "policy_torch_sps": "rollout, the built-in learner's policy step (torch, CUDA graph) between frames, no learning",
    "policy_engine_sps": "rollout, the actor as an engine pass, policy_steps_per_submit steps per submit, no learning",
    "ppo_sps": "PPO end to end (rollouts + updates, TASKS.md settings); ppo_policy says where the actor ran",
    "ppo_rollout_sps": "the rollout part of ppo_sps alone",
}


def run(task: str = "CartPole", env_counts=None, mode: str = "both", out_dir="benchmarks/results",
        device=None, backend: str = "auto", extend: bool = False, protocol: dict | None = None,
        minibatch: int | None = None, policy: str = "auto", compile: bool = False, fused_update: str = "auto") -> dict:
    """Measures each env count in `mode` (step, policy, ppo; both: step and ppo; all: the three);
    with `extend`, keeps doubling past the last count while step throughput still rises by 5 %
    or more. `policy` (auto, engine, torch): where PPO's actor runs; `compile`, `fused_update`:
    PPOConfig's.
    Prints a table; writes JSON and a PNG."""
    if mode not in MODES:
        raise ValueError(f"bench: mode must be one of {', '.join(MODES)}, got {mode!r}")
    p = {"warmup_steps": 64, "steps": 256, "warmup_updates": 5, "updates": 10, "rollout": 128, **(protocol or {})}
    rows, counts = [], list(env_counts or TASK_SWEEPS.get(task, PAPER_SWEEP))
    while counts:
        n = counts.pop(0)
        row = {"envs": n}
        if "step" in MODES[mode]:
            row.update(bench_step(task, n, device, p["warmup_steps"], p["steps"]))
        if "policy" in MODES[mode]:
            row.update(bench_policy(task, n, device, p["rollout"], max(p["steps"], p["rollout"]), p["rollout"]))
        if "ppo" in MODES[mode]:
            row.update(bench_ppo(task, n, device, p["warmup_updates"], p["updates"], p["rollout"], backend,
                                 minibatch=minibatch, policy=policy, compile=compile, fused_update=fused_update))
            row["ppo_minibatch"] = minibatch or ppo_config(task).minibatch
        row["engine_bytes_per_env"] = row["engine_bytes"] / n if row.get("engine_bytes") else None
        rows.append(row)
        print(f"  {n} envs: " + ", ".join(f"{k} {_num(row[k])}" for k in MEASURED if k in row)
              + (f", {row['scatterers'] // n:,} scatterers per env" if "scatterers" in row else ""), flush=True)
        stepped = "step" in MODES[mode]
        rising = stepped and (len(rows) < 2 or row["step_sps"] >= 1.05 * rows[-2]["step_sps"])
        if extend and not counts and rising:
            counts.append(2 * n)

    ref = REFERENCE.get(task, {})
    name = rows[0]["vulkan_device"] if rows else "?"
    backends = sorted({r["ppo_backend"] for r in rows if "ppo_backend" in r})
    print(f"\n{task} on {name} ({rows[0]['torch_device'] if rows else '?'})"
          + (f", PPO learner: {', '.join(backends)}" if backends else ""))
    keys = [k for k in MEASURED if any(k in r for r in rows)]
    ref_cols = [k for k in ref if k.startswith("paper")]
    print(f"{'envs':>7}" + "".join(f" {k:>17}" for k in keys) + f" {'engine KiB/env':>15}"
          + "".join(f" {k.replace('paper RTX 4090', '4090'):>12}" for k in ref_cols))
    for r in rows:
        mem = "n/a" if r["engine_bytes_per_env"] is None else f"{r['engine_bytes_per_env'] / 1024:.2f}"
        print(f"{r['envs']:>7}" + "".join(f" {_num(r.get(k)):>17}" for k in keys) + f" {mem:>15}"
              + "".join(f" {_num(ref[k].get(r['envs'])):>12}" for k in ref_cols))

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    stem = f"{task.lower()}_{'' if mode == 'both' else mode + '_'}{_slug(name)}"
    result = {
        "task": task, "device_name": name, "torch_device": rows[0]["torch_device"] if rows else None,
        "env_counts": [r["envs"] for r in rows], "mode": mode, "ppo_backend": backends,
        "command": " ".join(sys.argv), "protocol": p,
        "ppo": ppo_config(task, rollout=p["rollout"], minibatch=minibatch, compile=compile or None,
                          fused_update=fused_update).to_dict(),
        "torch": torch.__version__, "python": platform.python_version(), "time": time.strftime("%Y-%m-%dT%H:%M:%S"),
        "memory_note": "engine_bytes: sum of the engine's buffer sizes (internal + shared) on the Vulkan device; "
                       "excludes driver overhead and torch allocations",
        "measured": {k: MEASURED[k] for k in keys}, "results": rows,
        "reference": {k: {str(n): v for n, v in s.items()} for k, s in ref.items()},
        "reference_note": "paper: TASKS.md (RTX 4090, Vulkan); MJX: H100, step-only, figures as given in the brief",
    }
    (out / f"{stem}.json").write_text(json.dumps(result, indent=1))
    series = {}
    for key in keys:
        label = f"ours {key.removesuffix('_sps').replace('_', ' ')} ({name})"
        series[label] = {r["envs"]: r[key] for r in rows if key in r}
    series.update(ref)
    plot_throughput(series, out / f"{stem}.png", f"{task} throughput")
    print(f"wrote {out / stem}.json and .png")
    return result
