"""A dataset written here (either format) run again: `replay` steps the recorded task in one
batch with the recorded seed and actions and compares what the envs observe with what was
recorded."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from . import lerobot, robomimic


def load(path) -> tuple[dict, list[tuple[dict, np.ndarray, np.ndarray]]]:
    """A dataset written here, either format: (its source batch, [(source, actions, observations)])
    an episode, observations as (steps, ...) arrays (images decoded from the videos)."""
    path = Path(path)
    episodes_out = lerobot.read(path) if path.is_dir() else robomimic.read(path)
    if not episodes_out:
        raise ValueError(f"{path}: no episodes")
    return episodes_out[0][0], episodes_out


def replay(path, *, device=None) -> dict:
    """Runs a dataset's episodes again in one batch of the recorded task (each source env's
    episodes one after the other, the recorded seed, the recorded actions) and compares the
    observations with the recorded ones: returns the largest difference and the counts."""
    from cressim import envs

    import torch

    source, found = load(path)
    if "env" not in source:
        raise ValueError(f"{path}: exported from a twin recording ({source.get('bag')}); replay runs `cressim generate` "
                         "datasets (a recording's arm answered a person, not a policy the envs can run again)")
    by_env: dict[int, list] = {}
    for meta, actions, obs in found:
        by_env.setdefault(meta["env"], []).append((meta["start_step"], actions, obs))
    count = source["num_envs"]
    # envs 0..count-1 of the recorded batch, so every env draws what it drew when recorded
    env = envs.make(source["task"], num_envs=count, seed=source["seed"], device=device, **source["task_options"])
    steps = max(start + len(a) for eps in by_env.values() for start, a, _ in eps)
    actions = torch.zeros((steps, count, *env.single_action_space.shape), device=env.device)
    recorded = {}
    for e, eps in by_env.items():
        for start, a, obs in eps:
            actions[start:start + len(a), e] = torch.as_tensor(a.reshape(len(a), *env.single_action_space.shape))
            for k in range(len(a)):
                recorded[(start + k, e)] = obs[k]
    worst, compared = 0.0, 0
    obs, _ = env.reset()
    for k in range(steps):
        seen = obs.detach().cpu().numpy()
        for e in by_env:
            want = recorded.get((k, e))
            if want is not None:
                got = seen[e].reshape(want.shape).astype(np.float64)
                worst = max(worst, float(np.abs(got - want.astype(np.float64)).max()))
                compared += 1
        obs, *_ = env.step(actions[k])
    env.close()
    return {"episodes": len(found), "envs": len(by_env), "steps": steps, "frames_compared": compared,
            "max_abs_difference": worst}
