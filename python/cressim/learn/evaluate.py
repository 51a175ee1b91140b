"""`evaluate(checkpoint, ...)`: a trained policy's mean actions (no sampling) on its task, batched:
every env runs whole episodes until it has finished `episodes`; returns, lengths and how each
ended (terminated: the task's success where it ends on success; truncated: the time limit)."""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import torch

from .device import resolve_device, sync
from .policy import load_policy
from .video import EnvVideo


def evaluate(checkpoint, num_envs: int = 64, episodes: int = 1, device=None, seed: int = 0,
             task_options: dict | None = None, video_dir=None, video_envs=(0,)) -> dict:
    """`task_options` override the checkpoint's (e.g. a stricter success). `video_dir`: the
    evaluation of the envs `video_envs` written there as `eval_env<i>.mp4` (PyAV)."""
    from cressim import envs

    if num_envs < 1 or episodes < 1:
        raise ValueError(f"evaluate: num_envs and episodes must be positive, got {num_envs} and {episodes}")
    device = resolve_device(device)
    policy = load_policy(checkpoint, device="cpu" if device is None else device)
    options = {**policy.task_options, **(task_options or {})}
    rendering = {} if video_dir is None else {"render_mode": "rgb_array", "render_envs": tuple(video_envs)}
    env = envs.make(policy.task, num_envs=num_envs, device=device, seed=seed, final_observation=False, **rendering,
                    **options)
    video = EnvVideo(env) if video_dir is not None else None
    policy.actor.to(env.device)
    obs, _ = env.reset(seed=seed)
    if video is not None:
        video.capture()
    ended = torch.zeros(num_envs, dtype=torch.long, device=env.device)
    running = torch.zeros(num_envs, device=env.device)
    rows = []  # (return, length, terminated) per finished episode, gathered on the host once an episode ends
    start = time.perf_counter()
    steps = 0
    while bool((ended < episodes).any()):
        obs, reward, terminated, truncated, info = env.step(policy(obs).to(env.device))
        steps += 1
        if video is not None:
            video.capture()
        running += reward
        done = (terminated | truncated) & (ended < episodes)
        if bool(done.any()):  # a host read only on the steps where episodes end
            ids = torch.nonzero(done).flatten()
            for r, n, t in zip(running[ids].tolist(), info["finished_length"][ids].tolist(), terminated[ids].tolist()):
                rows.append((r, n, t))
            ended += done.long()
        running = torch.where(terminated | truncated, torch.zeros_like(running), running)
    sync(env.device)
    wall = time.perf_counter() - start
    videos = [str(p) for p in video.write(Path(video_dir) / "eval")] if video is not None else []
    returns, lengths, term = (np.array(c, dtype=np.float64) for c in zip(*rows))
    vulkan_device = env.engine.device["name"]
    env.close()
    return {"checkpoint": str(checkpoint), "task": policy.task, "task_options": options, "num_envs": num_envs,
            "episodes": len(rows), "seed": seed, "vulkan_device": vulkan_device, "device": str(env.device),
            "mean_return": float(returns.mean()), "mean_length": float(lengths.mean()),
            "terminated": float(term.mean()), "returns": returns.tolist(), "lengths": lengths.tolist(),
            "terminated_each": term.astype(bool).tolist(), "steps": steps, "wall_s": wall, "videos": videos}
