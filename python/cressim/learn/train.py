"""`train(...)`: PPO on a batched cressim task, with a progress bar, checkpoints, metrics and a
plot in `out_dir`; on several processes (GPUs) when started by torchrun (distributed.py)."""
from __future__ import annotations

import json
import math
import time
from pathlib import Path

import torch

from . import distributed
from .config import ppo_config
from .device import sync
from .engine_rollout import EngineRollout
from .learner import make_learner
from .plot import plot_training
from .rollout import EpisodeStats, collect_rollout
from .vec_env import CressimVecEnv
from .video import EnvVideo


def _progress(total: int, enabled: bool):
    try:
        from tqdm.auto import tqdm
    except ImportError:  # tqdm is optional on the GPU machine: print a line per update instead
        tqdm = None
    if tqdm is not None:
        return tqdm(total=total, disable=not enabled, unit="it", dynamic_ncols=True)

    class Lines:
        def __init__(self):
            self.n = 0

        def set_postfix(self, values):
            if enabled:
                print(f"{self.n + 1}/{total} " + " ".join(f"{k}={v}" for k, v in values.items()), flush=True)

        def update(self, k=1):
            self.n += k

        def close(self):
            pass

    return Lines()


def _fmt(x: float) -> str:
    return "-" if math.isnan(x) else f"{x:.1f}"


def train(task: str = "CartPole", num_envs: int = 4096, iterations: int = 200, device=None, seed: int = 0,
          out_dir="runs/cartpole", *, rollout: int | None = None, save_every: int = 50, backend: str = "auto",
          progress: bool = True, task_options: dict | None = None, video_envs=None, engine_rollout: bool = False,
          **ppo_overrides) -> dict:
    """Trains a PPO policy; returns a summary with the per-update history.

    device: the env's torch device (None: what the env picks, cuda where Vulkan shares memory
    with CUDA, else cpu); the learner runs there too. rollout and `ppo_overrides` (fields of
    PPOConfig) override TASKS.md's settings, e.g. for a short smoke run. task_options: keywords
    of the task's constructor (TissueRetract's observation="crtk"). video_envs: env indices whose
    rollout in each checkpoint's update is written as `video_<k>_env<i>.mp4` (PyAV; rank 0's envs).
    engine_rollout: the built-in learner's actor (an MLP, or TASKS.md's CNN) runs inside the
    engine's frame and whole rollouts run in one submit (engine_rollout.py); torch only learns.

    Under torchrun (WORLD_SIZE > 1) each process runs num_envs / WORLD_SIZE of the envs on its
    own GPU (or the cpu) and the learner's gradients are all-reduced; statistics cover every
    process, and rank 0 alone prints and writes. With the built-in learner the processes run
    exactly what one process with all the envs would (distributed.py, torch_ppo.py), up to the
    order of float sums.
    """
    from cressim import envs

    if engine_rollout and (video_envs is not None or backend not in ("auto", "torch")):
        raise ValueError("train(engine_rollout=True): the built-in learner (backend 'torch') without video_envs")
    backend = "torch" if engine_rollout else backend
    shard, env_device, vulkan = distributed.place(device)
    local_envs, offset = shard.envs(num_envs)
    out = Path(out_dir)
    if shard.leader:
        out.mkdir(parents=True, exist_ok=True)
    torch.manual_seed(seed)
    filmed = video_envs is not None and shard.leader
    rendering = {"render_mode": "rgb_array", "render_envs": tuple(video_envs)} if filmed else {}
    # PPO here bootstraps time-outs from the current value: the final observation is not read
    env = envs.make(task, num_envs=local_envs, device=env_device, seed=seed, env_offset=offset, vulkan_device=vulkan,
                    final_observation=False, **rendering, **(task_options or {}))
    video = EnvVideo(env) if filmed else None
    venv = CressimVecEnv(env)
    cfg = ppo_config(task, rollout=rollout, **ppo_overrides)
    alg, backend = make_learner(venv, cfg, backend)
    if backend == "rsl_rl" and shard.world > 1:  # its exploration noise: each process's own generator
        torch.manual_seed(seed + shard.rank)
    stats = EpisodeStats(local_envs, env.device)
    in_engine = EngineRollout(env, alg, seed=seed) if engine_rollout else None
    progress = progress and shard.leader
    meta = {"task": task, "task_options": dict(task_options or {}), "num_envs": num_envs, "seed": seed,
            "processes": shard.world, "device": str(env.device), "backend": backend, "engine_rollout": engine_rollout,
            "vulkan_device": env.engine.device["name"], "ppo": cfg.to_dict()}
    if progress:
        where = f"{local_envs} envs on each of {shard.world} processes" if shard.world > 1 else f"{num_envs} envs"
        in_frame = ", policy in the engine" if engine_rollout else ""
        print(f"PPO ({backend}{in_frame}) on {task}: {where} on {env.device} ({meta['vulkan_device']}), "
              f"{cfg.num_mini_batches(local_envs)} minibatches{' a process' if shard.world > 1 else ''} x {cfg.epochs} epochs, "
              f"rollout {cfg.rollout}")

    def save(it: int) -> Path:  # the leader's: every process holds the same weights
        path = out / f"model_{it}.pt"
        state = {**alg.save(), "iteration": it, "env_steps": it * num_envs * cfg.rollout, **meta}
        torch.save(state, path)
        if "actor_state_dict" in state:  # the actor alone (policy.pt): what load_policy and `cressim eval` read
            torch.save({k: v for k, v in state.items() if k not in ("critic_state_dict", "optimizer_state_dict")},
                       out / "policy.pt")
        return path

    history, bar, start = [], _progress(iterations, progress), time.perf_counter()
    checkpoint = None
    for it in range(1, iterations + 1):
        t0 = time.perf_counter()
        checkpointed = it % save_every == 0 or it == iterations
        filming = video is not None and checkpointed
        if in_engine is not None:
            in_engine.collect()
        else:
            collect_rollout(venv, alg, cfg.rollout, stats, after_step=video.capture if filming else None)
        sync(env.device)
        t1 = time.perf_counter()
        losses = alg.update()
        sync(env.device)
        dt = time.perf_counter() - t0
        rec = {"iteration": it, "env_steps": it * num_envs * cfg.rollout,
               **(in_engine.pop_stats() if in_engine is not None else stats.pop()), **losses,
               "steps_per_s": num_envs * cfg.rollout / dt, "rollout_steps_per_s": num_envs * cfg.rollout / (t1 - t0),
               "wall_s": time.perf_counter() - start}
        history.append(rec)
        bar.set_postfix({"len": _fmt(rec["mean_length"]), "rew": _fmt(rec["mean_return"]),
                         "term": _fmt(rec["terminated"]),
                         "sps": f"{rec['steps_per_s']:,.0f}"})
        bar.update(1)
        if shard.leader and checkpointed:
            checkpoint = save(it)
            if filming:
                video.write(out / f"video_{it}")
            (out / "metrics.json").write_text(json.dumps({**meta, "history": history}, indent=1))  # so far
    bar.close()
    title = f"PPO ({backend}) {task}, {num_envs} envs" + (f" on {shard.world} processes" if shard.world > 1 else "")
    plot = plot_training(history, out / "training.png", title) if shard.leader else None
    env.close()
    distributed.barrier()  # the leader's files are written before any process returns
    return {**meta, "rank": shard.rank, "history": history, "checkpoint": str(checkpoint) if checkpoint else None,
            "plot": str(plot) if plot else None,
            "wall_s": time.perf_counter() - start}
