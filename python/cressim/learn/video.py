"""MP4 videos of chosen envs: `EnvVideo(env)` keeps each step's images of the envs that the env
renders (made with render_mode="rgb_array", render_envs=...) and writes one MP4 per env
(`cressim.io.write_mp4`). `cressim train --video` and `cressim eval --video` use it."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from cressim.io import write_mp4


class EnvVideo:
    """The images of `env.render_envs`, a frame per `capture()` (after a step or reset), played at
    the env's `metadata["render_fps"]` (real time)."""

    def __init__(self, env):
        if env.render_mode != "rgb_array":
            raise ValueError(f"EnvVideo: {type(env).__name__} was made without render_mode='rgb_array'")
        self.env, self.fps, self.frames = env, env.metadata["render_fps"], []

    def capture(self) -> None:
        self.frames.append(self.env.render())

    def write(self, stem) -> list[Path]:
        """`<stem>_env<i>.mp4` for each rendered env i, from the frames captured since the last write."""
        if not self.frames:
            raise ValueError(f"EnvVideo: no frames captured for {stem}")
        frames, self.frames = np.stack(self.frames, axis=1), []  # (envs, T, H, W, 3)
        return [write_mp4(f"{stem}_env{env}.mp4", frames[k], self.fps) for k, env in enumerate(self.env.render_envs)]
