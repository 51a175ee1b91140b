"""`train(...)`: PPO on a batched cressim task, with a progress bar, checkpoints, metrics and a
plot in `out_dir`."""
from __future__ import annotations

import json
import math
import time
from pathlib import Path

import torch

from .config import ppo_config
from .learner import make_learner
from .plot import plot_training
from .rollout import EpisodeStats, resolve_device, run_update, sync
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
          progress: bool = True, task_options: dict | None = None, video_envs=None, **ppo_overrides) -> dict:
    """Trains a PPO policy; returns a summary with the per-update history.

    device: the env's torch device (None: what the env picks, cuda where Vulkan shares memory
    with CUDA, else cpu); the learner runs there too. rollout and `ppo_overrides` (fields of
    PPOConfig) override TASKS.md's settings, e.g. for a short smoke run. task_options: keywords
    of the task's constructor (TissueRetract's observation="crtk"). video_envs: env indices whose
    rollout in each checkpoint's update is written as `video_<k>_env<i>.mp4` (PyAV).
    """
    from cressim import envs

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    torch.manual_seed(seed)
    # PPO here bootstraps time-outs from the current value: the final observation is not read
    rendering = {} if video_envs is None else {"render_mode": "rgb_array", "render_envs": tuple(video_envs)}
    env = envs.make(task, num_envs=num_envs, device=resolve_device(device), seed=seed, final_observation=False,
                    **rendering, **(task_options or {}))
    video = EnvVideo(env) if video_envs is not None else None
    venv = CressimVecEnv(env)
    cfg = ppo_config(task, rollout=rollout, **ppo_overrides)
    alg, backend = make_learner(venv, cfg, backend)
    stats = EpisodeStats(num_envs, env.device)
    meta = {"task": task, "task_options": dict(task_options or {}), "num_envs": num_envs, "seed": seed,
            "device": str(env.device), "backend": backend,
            "vulkan_device": env.engine.device["name"], "ppo": cfg.to_dict()}
    if progress:
        print(f"PPO ({backend}) on {task}: {num_envs} envs on {env.device} ({meta['vulkan_device']}), "
              f"{cfg.num_mini_batches(num_envs)} minibatches x {cfg.epochs} epochs, rollout {cfg.rollout}")

    def save(it: int) -> Path:
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
        losses = run_update(venv, alg, cfg.rollout, stats, after_step=video.capture if filming else None)
        sync(env.device)
        dt = time.perf_counter() - t0
        rec = {"iteration": it, "env_steps": it * num_envs * cfg.rollout, **stats.pop(), **losses,
               "steps_per_s": num_envs * cfg.rollout / dt, "wall_s": time.perf_counter() - start}
        history.append(rec)
        bar.set_postfix({"len": _fmt(rec["mean_length"]), "rew": _fmt(rec["mean_return"]),
                         "term": _fmt(rec["terminated"]),
                         "sps": f"{rec['steps_per_s']:,.0f}"})
        bar.update(1)
        if checkpointed:
            checkpoint = save(it)
            if filming:
                video.write(out / f"video_{it}")
            (out / "metrics.json").write_text(json.dumps({**meta, "history": history}, indent=1))  # so far
    bar.close()
    plot = plot_training(history, out / "training.png", f"PPO ({backend}) {task}, {num_envs} envs")
    env.close()
    return {**meta, "history": history, "checkpoint": str(checkpoint), "plot": str(plot),
            "wall_s": time.perf_counter() - start}
