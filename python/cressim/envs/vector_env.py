"""Batched environments on torch tensors, stepped as one GPU frame per step.

The conventions are Isaac Lab's and gymnasium's VectorEnv: `reset() -> (obs, info)`,
`step(actions) -> (obs, reward, terminated, truncated, info)`, finished envs reset
automatically on the GPU (the returned obs of a finished env is its next episode's first).
Task logic runs in HLSL custom passes; this class only records the frame and exposes the
task's shared buffers as tensors without copies (host memory on lavapipe, CUDA memory on
NVIDIA through Vulkan external memory).
"""
from __future__ import annotations

import math

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import torch

import cressim


@dataclass
class Space:
    """A box space: shape, bounds, dtype (what gymnasium.spaces.Box says, without the import)."""

    shape: tuple
    low: float = -np.inf
    high: float = np.inf
    dtype: torch.dtype = torch.float32

    def sample(self, batch: int, device) -> torch.Tensor:
        lo, hi = max(self.low, -1.0), min(self.high, 1.0)
        return lo + (hi - lo) * torch.rand((batch, *self.shape), device=device, dtype=self.dtype)


@dataclass
class TaskBuffers:
    """The shared buffers every task has; a task adds its own in `extra`."""

    actions: cressim.Buffer
    observations: cressim.Buffer
    rewards: cressim.Buffer
    terminated: cressim.Buffer
    truncated: cressim.Buffer
    episode_length: cressim.Buffer
    finished_length: cressim.Buffer
    extra: dict = field(default_factory=dict)


def tensor_view(buffer: cressim.Buffer, device: torch.device) -> torch.Tensor:
    """A torch tensor sharing the buffer's memory on `device` (no copy)."""
    t = torch.from_dlpack(buffer)
    if t.device != device:
        raise RuntimeError(f"buffer {buffer.key!r} lives on {t.device}, not {device}: the zero-copy path for "
                           f"{device} is not available on this Vulkan device ({cressim.__name__} info shows why)")
    return t


class VectorEnv:
    """Base of the batched tasks. Subclasses build the scene (`build_world`), name their HLSL
    file and its three entry points, and fill the task constants."""

    hlsl: Path  # task passes: `entries` (evaluate also as evaluate_reset_all)
    entries = ("apply_action", "evaluate", "observe")
    observation_space: Space
    action_space: Space
    max_episode_steps: int

    def __init__(self, num_envs: int, *, device: str | torch.device | None = None, seed: int = 0,
                 validation: bool | None = None, vulkan_device: str | None = None, cuda_sync: str = "semaphore",
                 env_offset: int = 0):
        """`env_offset`: where env 0 sits in a larger batch that this one is a shard of (one process's
        part under torch.distributed): env k draws the random numbers of env env_offset + k there,
        so the shards together run exactly the envs of the one large batch."""
        if isinstance(env_offset, bool) or not isinstance(env_offset, (int, np.integer)) or env_offset < 0:
            raise ValueError(f"{type(self).__name__}: env_offset must be an integer >= 0, got {env_offset!r}")
        self.num_envs, self.env_offset = num_envs, int(env_offset)
        world = self.build_world(num_envs)
        self.engine = cressim.Engine(world, validation=validation, device=vulkan_device)
        self.engine.physics = self.physics_settings()
        self.engine.prepare()
        self.engine.upload_world()
        self.device = torch.device(device) if device is not None else self.default_device()
        if self.device.type == "cuda" and self.device.index is None:
            self.device = torch.device("cuda", torch.cuda.current_device())
        self.seed = seed
        self.buffers = self._create_buffers()
        self.passes = self._create_passes()
        if self.device.type == "cuda":  # frames wait for the actions written on torch's stream
            if cuda_sync not in ("semaphore", "host"):
                raise ValueError(f"cuda_sync={cuda_sync!r}: use 'semaphore' (on the GPU) or 'host'")
            self.engine.set_cuda_stream(torch.cuda.current_stream(self.device).cuda_stream,
                                        host_sync=cuda_sync == "host")
        self.actions = tensor_view(self.buffers.actions, self.device)
        self.obs = tensor_view(self.buffers.observations, self.device)
        self.reward = tensor_view(self.buffers.rewards, self.device)
        self.terminated = _bool_view(tensor_view(self.buffers.terminated, self.device))
        self.truncated = _bool_view(tensor_view(self.buffers.truncated, self.device))
        self.episode_length = tensor_view(self.buffers.episode_length, self.device)
        self.finished_length = tensor_view(self.buffers.finished_length, self.device)
        self.health = tensor_view(self.engine.buffer("env.health"), self.device).view(torch.int32)

    # --- what a task provides -------------------------------------------------------------
    def build_world(self, num_envs: int) -> cressim.World:
        raise NotImplementedError

    def physics_settings(self) -> cressim.PhysicsSettings:
        return cressim.PhysicsSettings()

    def task_constants(self, reset_all: bool) -> dict:
        raise NotImplementedError

    def task_bindings(self) -> dict:
        """Extra HLSL bindings (name -> buffer or key) beyond the common ones."""
        return {}

    def act(self) -> None:
        """What the actions do before the frame's physics: the task's `apply_action` pass; a task
        that moves its bodies in torch (no `apply_action` in `entries`) does it here instead."""
        self.engine.execute_compute_pass(self.passes["apply_action"])

    def sense(self) -> None:
        """Sensor stages the observation reads, recorded before `observe` (none by default)."""

    # --- the batched API ---------------------------------------------------------------------
    def default_device(self) -> torch.device:
        probe = self.engine.buffer("env.health")
        return torch.device("cpu") if probe.host_visible else torch.device("cuda", 0)

    def reset(self, *, seed: int | None = None):
        """Starts a new episode in every env; returns (obs, info)."""
        if seed is not None and seed != self.seed:
            self.seed = seed
            for key in ("evaluate", "evaluate_reset_all"):
                self.passes[key].set_constant("seed", seed)
        self._frame(reset_all=True)
        return self.obs, self._info()

    def step(self, actions: torch.Tensor):
        """Applies `actions` (num_envs, *action_space.shape) and advances one frame. Writing the
        actions into `env.actions` in place and passing that tensor saves the copy."""
        if actions.data_ptr() != self.actions.data_ptr():
            self.actions.copy_(actions.reshape(self.actions.shape))
        self._frame(reset_all=False)
        return self.obs, self.reward, self.terminated, self.truncated, self._info()

    def close(self):
        self.engine = None

    # --- internals ---------------------------------------------------------------------------
    def _info(self) -> dict:
        return {"episode_length": self.episode_length, "finished_length": self.finished_length,
                "health": self.health}

    def _create_buffers(self) -> TaskBuffers:
        # flags and counters are int32: torch's uint32 support on CUDA is partial
        n, e = self.num_envs, self.engine
        return TaskBuffers(
            actions=e.create_shared_buffer("actions", (n, *self.action_space.shape), "float32"),
            observations=e.create_shared_buffer("observations", (n, *self.observation_space.shape),
                                                str(self.observation_space.dtype).removeprefix("torch.")),
            rewards=e.create_shared_buffer("rewards", n, "float32"),
            terminated=e.create_shared_buffer("terminated", n, "int32"),
            truncated=e.create_shared_buffer("truncated", n, "int32"),
            episode_length=e.create_shared_buffer("episode_length", n, "int32"),
            finished_length=e.create_shared_buffer("finished_length", n, "float32"))

    def _create_passes(self) -> dict:
        b = self.buffers
        common = {"actions": b.actions, "observations": b.observations, "rewards": b.rewards,
                  "terminated": b.terminated, "truncated": b.truncated, "episode_length": b.episode_length,
                  "finished_length": b.finished_length, "reset_mask": "env.reset_mask"}
        common.update(self.task_bindings())
        source = self.hlsl.read_text()
        declared = _declared(source)
        shard = {"env_offset": self.env_offset} if "env_offset" in declared else {}
        passes = {}
        # named by the file: compiler errors give its path and line, and "episode.hlsli" beside it resolves
        for entry in self.entries:
            passes[entry] = self.engine.create_compute_pass(
                source, name=str(self.hlsl), entry=entry, threads=self.num_envs,
                bindings={k: v for k, v in common.items() if k in declared},
                constants={**self.task_constants(reset_all=False), **shard})
        passes["evaluate_reset_all"] = self.engine.create_compute_pass(
            source, name=str(self.hlsl), entry="evaluate", threads=self.num_envs,
            bindings={k: v for k, v in common.items() if k in declared},
            constants={**self.task_constants(reset_all=True), **shard})
        return passes

    def _frame(self, reset_all: bool):
        e, p = self.engine, self.passes
        if reset_all:  # no physics: flag and randomise every env, reset, observe
            e.execute_compute_pass(p["evaluate_reset_all"])
        else:
            self.act()
            e.step_physics()
            e.execute_compute_pass(p["evaluate"])
        e.reset_flagged_envs()
        self.sense()
        e.execute_compute_pass(p["observe"])
        e.end_frame()


def checked_number(task: str, name: str, value, low: float = 0.0, high: float = math.inf, *,
                   with_low: bool = False, with_high: bool = False) -> float:
    """`value` as a float between low and high, those ends excluded unless `with_low` / `with_high`
    (a task's constructor argument); raises naming the task and the argument otherwise."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        x = math.nan
    above = low <= x if with_low else low < x
    below = x <= high if with_high else x < high
    if not (above and below):
        raise ValueError(f"{task}: {name} must be a number in {'[' if with_low else '('}{low}, {high}"
                         f"{']' if with_high else ')'}, got {value!r}")
    return x


def _bool_view(flags: torch.Tensor) -> torch.Tensor:
    """0/1 int32 flags seen as bools without a kernel: the low byte of each (little-endian)."""
    return flags.view(torch.uint8)[::4].view(torch.bool)


def _declared(source: str) -> set:
    """Identifiers in the HLSL source (bindings the task file does not mention are left out)."""
    import re

    return set(re.findall(r"[A-Za-z_][A-Za-z0-9_]*", source))
