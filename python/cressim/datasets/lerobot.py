"""Clips (clips.py) as a LeRobot v2.1 dataset: per episode a parquet file of actions, rewards,
states and timestamps, an MP4 of image observations (lossless H.264), and meta/ (info.json,
episodes.jsonl, episodes_stats.jsonl, tasks.jsonl); and such a dataset read back."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from cressim.io import read_mp4, write_mp4

from .clips import clips, is_image

LEROBOT_VERSION = "v2.1"
CHUNK = 1000  # episodes a chunk folder (LeRobot's chunks_size)


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
    image = is_image(found[0].obs.shape[1:])
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


def read(path) -> list[tuple[dict, np.ndarray, np.ndarray]]:
    """A dataset `to_lerobot` wrote: [(source, actions, observations)] an episode, observations
    as (steps, ...) arrays (images decoded from the videos)."""
    import pyarrow.parquet as pq

    path = Path(path)
    out = []
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
        out.append((line["cressim"], actions, obs))
    return out
