"""Rollouts recorded by `cressim generate` (rollouts.py) and recordings of the twin as
imitation-learning datasets: LeRobot's v2.1 layout and robomimic's HDF5; a rollout dataset
replayed in a batch of envs. Both sources become clips (`Clip`: one episode's arrays), which the
two writers take.

An episode is one env's steps from a reset to the step that ended it (terminated or truncated);
an env's steps after its last ending (an episode cut off by the recording's end) are left out.
Each episode keeps where it came from (the env's index in the recorded batch and the step it
started at), so a dataset can be replayed: `replay` runs the task again with the recorded seed,
env by env, feeding the recorded actions, and compares what the envs observe with what was
recorded.

Observations of shape (H, W, 3) are images (LeRobot: an MP4 per episode, `observation.image`;
robomimic: obs/image, uint8); any other observation is a flat state (`observation.state`,
obs/state). Timestamps are the simulated time from the episode's start, k dt. A twin recording
is one episode sampled at a fixed rate from its first to its last arm command (`bag_clips`).
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..io import read_mp4, write_mp4
from .rollouts import read

LEROBOT_VERSION = "v2.1"
CHUNK = 1000  # episodes a chunk folder (LeRobot's chunks_size)


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


def _is_image(shape) -> bool:
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
        return self.state if self.state is not None else (None if _is_image(self.obs.shape[1:]) else self.obs)


def rollout_clips(src) -> tuple[dict, list[Clip]]:
    """A `cressim generate` folder's complete episodes: (what the dataset is, its clips)."""
    index, arrays, found = _load(src)
    out = []
    for ep in found:
        n = ep.stop - ep.start
        obs = arrays["observation"][ep.start:ep.stop, ep.env]
        # the observation after the last step is the next episode's first (reset within the step)
        after = arrays["observation"][ep.start + 1:ep.stop + 1, ep.env]
        flat = (lambda a: a) if _is_image(obs.shape[1:]) else (lambda a: a.reshape(len(a), -1).astype(np.float32))
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
    from .reader import read_messages

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


def to_lerobot(src, dst, *, instruction: str | None = None, **kwargs) -> Path:
    """Writes the episodes of `src` (clips) as a LeRobot v2.1 dataset in `dst` (new)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    about, found = clips(src, **kwargs)
    dst = Path(dst)
    if dst.exists():
        raise FileExistsError(f"{dst} exists: export into a new folder")
    (dst / "meta").mkdir(parents=True)
    fps = about["fps"]
    image = _is_image(found[0].obs.shape[1:])
    obs_key = "observation.image" if image else "observation.state"
    states = found[0].states()
    action_size = found[0].action.shape[1]
    task_text = instruction or f"cressim {about['name']}"
    features = {
        "action": {"dtype": "float32", "shape": [action_size], "names": None},
        "next.reward": {"dtype": "float32", "shape": [1], "names": None},
        "next.done": {"dtype": "bool", "shape": [1], "names": None},
        "timestamp": {"dtype": "float32", "shape": [1], "names": None},
        "frame_index": {"dtype": "int64", "shape": [1], "names": None},
        "episode_index": {"dtype": "int64", "shape": [1], "names": None},
        "index": {"dtype": "int64", "shape": [1], "names": None},
        "task_index": {"dtype": "int64", "shape": [1], "names": None},
    }
    if image:
        features[obs_key] = {"dtype": "video", "shape": list(found[0].obs.shape[1:]),
                             "names": ["height", "width", "channels"],
                             "info": {"video.fps": fps, "video.codec": "h264", "video.pix_fmt": "yuv444p",
                                      "video.is_depth_map": False, "has_audio": False}}
    if states is not None:
        features["observation.state"] = {"dtype": "float32", "shape": [states.shape[1]], "names": None}
    stats_lines, episode_lines, frame = [], [], 0
    for e, clip in enumerate(found):
        n = len(clip.action)
        done = np.zeros(n, bool)
        done[-1] = True
        columns = {"action": pa.array(list(clip.action), type=pa.list_(pa.float32(), action_size)),
                   "next.reward": pa.array(clip.reward), "next.done": pa.array(done),
                   "timestamp": pa.array(clip.time.astype(np.float32)),
                   "frame_index": pa.array(np.arange(n, dtype=np.int64)),
                   "episode_index": pa.array(np.full(n, e, np.int64)),
                   "index": pa.array(np.arange(frame, frame + n, dtype=np.int64)),
                   "task_index": pa.array(np.zeros(n, np.int64))}
        values = {"action": clip.action, "next.reward": clip.reward[:, None]}
        if image:
            write_mp4(dst / "videos" / f"chunk-{e // CHUNK:03d}" / obs_key / f"episode_{e:06d}.mp4", clip.obs, fps,
                      lossless=True)
        if states is not None:
            state = clip.states()
            columns["observation.state"] = pa.array(list(state), type=pa.list_(pa.float32(), state.shape[1]))
            values["observation.state"] = state
        path = dst / "data" / f"chunk-{e // CHUNK:03d}" / f"episode_{e:06d}.parquet"
        path.parent.mkdir(parents=True, exist_ok=True)
        pq.write_table(pa.table(columns), path)
        episode_lines.append({"episode_index": e, "tasks": [task_text], "length": n, "cressim": clip.source})
        stats_lines.append({"episode_index": e, "stats": {k: _stats(v) for k, v in values.items()}})
        frame += n
    info = {"codebase_version": LEROBOT_VERSION, "robot_type": about["robot"],
            "total_episodes": len(found), "total_frames": frame, "total_tasks": 1,
            "total_videos": len(found) if image else 0, "total_chunks": (len(found) - 1) // CHUNK + 1,
            "chunks_size": CHUNK, "fps": fps, "splits": {"train": f"0:{len(found)}"},
            "data_path": "data/chunk-{episode_chunk:03d}/episode_{episode_index:06d}.parquet",
            "video_path": "videos/chunk-{episode_chunk:03d}/{video_key}/episode_{episode_index:06d}.mp4" if image else None,
            "features": features}
    (dst / "meta" / "info.json").write_text(json.dumps(info, indent=2))
    _jsonl(dst / "meta" / "episodes.jsonl", episode_lines)
    _jsonl(dst / "meta" / "episodes_stats.jsonl", stats_lines)
    _jsonl(dst / "meta" / "tasks.jsonl", [{"task_index": 0, "task": task_text}])
    return dst


def _stats(v: np.ndarray) -> dict:
    return {"min": v.min(0).tolist(), "max": v.max(0).tolist(), "mean": v.mean(0).tolist(),
            "std": v.std(0).tolist(), "count": [int(v.shape[0])]}


def _jsonl(path: Path, lines: list) -> None:
    path.write_text("".join(json.dumps(line) + "\n" for line in lines))


def to_robomimic(src, dst, **kwargs) -> Path:
    """Writes the episodes of `src` (clips) as a robomimic HDF5 file `dst` (new): data/demo_k with
    actions, rewards, dones, obs/<state|image> (and obs/state beside an image), next_obs where
    the recording holds it, and its source in attributes."""
    import h5py

    about, found = clips(src, **kwargs)
    dst = Path(dst)
    if dst.exists():
        raise FileExistsError(f"{dst} exists: export to a new file")
    dst.parent.mkdir(parents=True, exist_ok=True)
    key = "image" if _is_image(found[0].obs.shape[1:]) else "state"
    with h5py.File(dst, "w") as f:
        data = f.create_group("data")
        data.attrs["env_args"] = json.dumps(about["env_args"])
        total = 0
        for e, clip in enumerate(found):
            n = len(clip.action)
            g = data.create_group(f"demo_{e}")
            g.attrs["num_samples"] = n
            g.attrs["cressim"] = json.dumps(clip.source)
            g.create_dataset("actions", data=clip.action)
            g.create_dataset("rewards", data=clip.reward)
            dones = np.zeros(n, np.uint8)
            dones[-1] = 1
            g.create_dataset("dones", data=dones)
            g.create_dataset(f"obs/{key}", data=clip.obs)
            if key == "image" and clip.state is not None:
                g.create_dataset("obs/state", data=clip.state)
            if clip.next_obs is not None:
                g.create_dataset(f"next_obs/{key}", data=clip.next_obs)
            total += n
        data.attrs["total"] = total
        f.create_dataset("mask/train", data=np.array([f"demo_{e}".encode() for e in range(len(found))]))
    return dst


def load(path) -> tuple[dict, list[tuple[dict, np.ndarray, np.ndarray]]]:
    """A dataset written here, either format: (its source batch, [(source, actions, observations)])
    an episode, observations as (steps, ...) arrays (images decoded from the videos)."""
    path = Path(path)
    episodes_out = []
    if path.is_dir():
        import pyarrow.parquet as pq

        info = json.loads((path / "meta" / "info.json").read_text())
        lines = [json.loads(x) for x in (path / "meta" / "episodes.jsonl").read_text().splitlines()]
        image = "observation.image" in info["features"]
        for line in lines:
            e = line["episode_index"]
            table = pq.read_table(path / info["data_path"].format(episode_chunk=e // CHUNK, episode_index=e))
            actions = np.stack(table.column("action").to_numpy(zero_copy_only=False))
            if image:
                obs = read_mp4(path / info["video_path"].format(episode_chunk=e // CHUNK, episode_index=e,
                                                                   video_key="observation.image"))
            else:
                obs = np.stack(table.column("observation.state").to_numpy(zero_copy_only=False))
            episodes_out.append((line["cressim"], actions, obs))
    else:
        import h5py

        with h5py.File(path, "r") as f:
            demos = sorted(f["data"].keys(), key=lambda k: int(k.split("_")[1]))
            for name in demos:
                g = f["data"][name]
                key = "image" if "image" in g["obs"] else "state"
                episodes_out.append((json.loads(g.attrs["cressim"]), g["actions"][()], g["obs"][key][()]))
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
