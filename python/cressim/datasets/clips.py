"""Rollouts recorded by `cressim generate` (rollouts.py) and recordings of the twin as clips
(`Clip`: one episode's arrays), which the dataset writers (lerobot.py, robomimic.py) take.

An episode is one env's steps from a reset to the step that ended it (terminated or truncated);
an env's steps after its last ending (an episode cut off by the recording's end) are left out.
Each episode keeps where it came from (the env's index in the recorded batch and the step it
started at), so a dataset can be replayed (replay.py).

Observations of shape (H, W, 3) are images; any other observation is a flat state. Timestamps
are the simulated time from the episode's start, k dt. A twin recording is one episode sampled
at a fixed rate from its first to its last arm command (`bag_clips`).
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cressim.record.reader import read_messages

from .rollouts import read


@dataclass(frozen=True)
class Episode:
    env: int    # the env's index in the recorded batch
    start: int  # its first step in the recording
    stop: int   # one past its last step (the one that ended it)


def episodes(arrays: dict) -> list[Episode]:
    """The complete episodes of a recording's arrays (steps, envs, ...), env by env, in order."""
    done = (arrays["terminated"] != 0) | (arrays["truncated"] != 0)
    out = []
    for env in range(done.shape[1]):
        start = 0
        for step in np.flatnonzero(done[:, env]):
            out.append(Episode(env, start, int(step) + 1))
            start = int(step) + 1
    return out


def is_image(shape) -> bool:
    """An (H, W, 3) observation: an image."""
    return len(shape) == 3 and shape[-1] == 3


def _load(src) -> tuple[dict, dict, list[Episode]]:
    src = Path(src)
    index = json.loads((src / "index.json").read_text())
    arrays = read(src)
    found = episodes(arrays)
    if not found:
        raise ValueError(f"{src}: no env finished an episode in {index['steps']} steps; record more steps")
    return index, arrays, found


def _source(index: dict, episode: Episode) -> dict:
    return {"task": index["task"], "task_options": index["task_options"], "seed": index["seed"],
            "num_envs": index["num_envs"], "env": episode.env, "start_step": episode.start}


@dataclass
class Clip:
    """One episode as the writers take it: per step the observation (a flat state, or an (H, W, 3)
    uint8 image), the action, the reward and the time from the episode's start (s); the
    observation after each step where the recording holds it; a state beside an image observation;
    where the episode came from."""
    obs: np.ndarray
    action: np.ndarray
    reward: np.ndarray
    time: np.ndarray
    source: dict
    next_obs: np.ndarray | None = None
    state: np.ndarray | None = None

    def states(self) -> np.ndarray | None:
        """The flat state of each step: `state`, or the observation where that is no image."""
        return self.state if self.state is not None else (None if is_image(self.obs.shape[1:]) else self.obs)


def rollout_clips(src) -> tuple[dict, list[Clip]]:
    """A `cressim generate` folder's complete episodes: (what the dataset is, its clips)."""
    index, arrays, found = _load(src)
    out = []
    for ep in found:
        n = ep.stop - ep.start
        obs = arrays["observation"][ep.start:ep.stop, ep.env]
        # the observation after the last step is the next episode's first (reset within the step)
        after = arrays["observation"][ep.start + 1:ep.stop + 1, ep.env]
        flat = (lambda a: a) if is_image(obs.shape[1:]) else (lambda a: a.reshape(len(a), -1).astype(np.float32))
        out.append(Clip(flat(obs), arrays["action"][ep.start:ep.stop, ep.env].reshape(n, -1).astype(np.float32),
                          arrays["reward"][ep.start:ep.stop, ep.env].astype(np.float32), np.arange(n) * index["dt"],
                        _source(index, ep), flat(after) if len(after) == n else None))
    about = {"name": index["task"], "fps": 1.0 / index["dt"], "robot": f"cressim.{index['task']}",
             "env_args": {"env_name": index["task"], "type": "cressim",
                          "env_kwargs": {**index["task_options"], "seed": index["seed"]}}}
    return about, out


def bag_clips(bag, *, fps: float = 30.0, ns: str = "PSM1") -> tuple[dict, list[Clip]]:
    """A recording of the twin (`cressim_twin -p record:=BAG`, or `cressim record`) as one episode
    sampled at `fps` from its first to its last arm command: the state is the latest measured
    joints and jaw (7), the action the latest servo_jp and jaw/servo_jp command (7; the measured
    values before any), the image the latest camera image where the bag has one; the reward is
    0 (a recording has none)."""
    p = f"/{ns.strip('/')}/"
    topics = {f"{p}measured_js": "q", f"{p}jaw/measured_js": "jaw", f"{p}servo_jp": "cmd", f"{p}jaw/servo_jp": "jaw_cmd",
              "/camera/color/image_raw": "image"}
    series: dict = {k: ([], []) for k in topics.values()}
    for m, msg in read_messages(bag, list(topics), decode=True):
        key = topics[m.topic]
        value = (np.frombuffer(bytes(msg.data), np.uint8).reshape(msg.height, msg.width, 3) if key == "image"
                 else np.asarray(msg.position, dtype=np.float64))
        series[key][0].append(m.log_time)
        series[key][1].append(value)
    if not series["cmd"][0] or not series["q"][0]:
        raise ValueError(f"{bag}: no {p}servo_jp commands or no {p}measured_js: nothing to learn from")
    t0, t1 = series["cmd"][0][0], series["cmd"][0][-1]
    times = np.arange(t0, t1 + 1, int(round(1e9 / fps)), dtype=np.int64)

    def latest(key, fallback=None):
        stamps, values = series[key]
        if not stamps:
            return None if fallback is None else latest(fallback)
        idx = np.searchsorted(np.asarray(stamps), times, side="right") - 1
        first = values[0]
        return np.stack([values[i] if i >= 0 else first for i in idx])

    state = np.concatenate([latest("q"), latest("jaw") if series["jaw"][0] else np.zeros((len(times), 1))], 1)
    action = np.concatenate([latest("cmd"), latest("jaw_cmd", "jaw") if series["jaw"][0] or series["jaw_cmd"][0]
                             else np.zeros((len(times), 1))], 1)
    image = latest("image")
    n = len(times)
    source = {"bag": str(bag), "namespace": ns, "start_ns": int(t0), "fps": fps}
    state = state.astype(np.float32)
    clip = Clip(image if image is not None else state, action.astype(np.float32), np.zeros(n, np.float32),
                (times - t0) * 1e-9, source, state=state if image is not None else None)
    about = {"name": f"dVRK {ns} (cressim twin)", "fps": fps, "robot": "dvrk_psm",
             "env_args": {"env_name": "cressim_twin", "type": "ros2", "env_kwargs": {"namespace": ns}}}
    return about, [clip]


def clips(src, **kwargs) -> tuple[dict, list[Clip]]:
    """`src` as clips: a `cressim generate` folder (index.json) or a twin recording (a rosbag2 folder)."""
    src = Path(src)
    if (src / "index.json").is_file():
        return rollout_clips(src)
    if (src / "metadata.yaml").is_file() or list(src.glob("*.mcap")):
        return bag_clips(src, **kwargs)
    raise ValueError(f"{src}: neither a `cressim generate` folder (index.json) nor a rosbag2 recording (*.mcap)")
