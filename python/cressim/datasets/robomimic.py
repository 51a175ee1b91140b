"""Clips (clips.py) as a robomimic HDF5 file, and such a file read back."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .clips import clips, is_image


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
    key = "image" if is_image(found[0].obs.shape[1:]) else "state"
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


def read(path) -> list[tuple[dict, np.ndarray, np.ndarray]]:
    """A file `to_robomimic` wrote: [(source, actions, observations)] a demo, in demo order."""
    import h5py

    out = []
    with h5py.File(path, "r") as f:
        demos = sorted(f["data"].keys(), key=lambda k: int(k.split("_")[1]))
        for name in demos:
            g = f["data"][name]
            key = "image" if "image" in g["obs"] else "state"
            out.append((json.loads(g.attrs["cressim"]), g["actions"][()], g["obs"][key][()]))
    return out
