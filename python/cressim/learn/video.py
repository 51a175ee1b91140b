"""MP4 videos of chosen envs (PyAV, H.264): `EnvVideo(env)` keeps each step's images of the envs
that the env renders (made with render_mode="rgb_array", render_envs=...) and writes one MP4 per
env. `cressim train --video` and `cressim eval --video` use it. PyAV is imported when a video is
written, so the rest of cressim does not need it."""
from __future__ import annotations

from pathlib import Path

import numpy as np


def write_mp4(path, frames, fps: int) -> Path:
    """Writes `frames` ((T, H, W, 3) uint8, H and W even) as an H.264 MP4; returns the path."""
    import av

    frames = np.asarray(frames)
    if frames.ndim != 4 or frames.shape[-1] != 3 or frames.dtype != np.uint8 or len(frames) == 0:
        raise ValueError(f"write_mp4: {path}: frames must be (T > 0, H, W, 3) uint8, got {frames.shape} {frames.dtype}")
    if frames.shape[1] % 2 or frames.shape[2] % 2:
        raise ValueError(f"write_mp4: {path}: H.264 (yuv420p) needs an even width and height, got {frames.shape[1:3]}")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with av.open(str(path), "w") as container:
        stream = container.add_stream("libx264", rate=fps)
        stream.height, stream.width = frames.shape[1:3]
        stream.pix_fmt = "yuv420p"
        for image in frames:
            container.mux(stream.encode(av.VideoFrame.from_ndarray(image, format="rgb24")))
        container.mux(stream.encode())  # flush the encoder
    return path


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
