"""Batched environments on torch tensors, stepped as one GPU frame per step.

Every task is a `gymnasium.vector.VectorEnv` (gymnasium 1.x): `reset() -> (obs, info)`,
`step(actions) -> (obs, reward, terminated, truncated, info)`, spaces from `gymnasium.spaces`
(`single_observation_space` per env, `observation_space` batched). Finished envs reset on the GPU
within the step (autoreset mode SAME_STEP, declared in `metadata`): the returned obs of a finished
env is its next episode's first, and its last one is in `info["final_obs"]` (rows where
`info["_final_obs"]`), written by the task's observe pass before the reset. Task logic runs in
HLSL custom passes; this class only records the frame and exposes the task's shared buffers as
tensors without copies (host memory on lavapipe, CUDA memory on NVIDIA through Vulkan external
memory).
"""
from __future__ import annotations

import math

from dataclasses import dataclass, field
from pathlib import Path

import gymnasium
import numpy as np
import torch
from gymnasium.spaces import Box
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space

import cressim
from cressim.randomization import Randomizer, load_terms
from cressim.scene_file import _quat_look_at


def box(shape: tuple, low: float = -np.inf, high: float = np.inf, dtype=np.float32) -> Box:
    """A task's per-env space: a gymnasium Box of `shape` with the same bounds everywhere."""
    return Box(low, high, shape, dtype)


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
    final_observations: cressim.Buffer | None = None  # each env's observation before this step's reset
    extra: dict = field(default_factory=dict)


def tensor_view(buffer: cressim.Buffer, device: torch.device) -> torch.Tensor:
    """A torch tensor sharing the buffer's memory on `device` (no copy)."""
    t = torch.from_dlpack(buffer)
    if t.device != device:
        raise RuntimeError(f"buffer {buffer.key!r} lives on {t.device}, not {device}: the zero-copy path for "
                           f"{device} is not available on this Vulkan device ({cressim.__name__} info shows why)")
    return t


ENV_GROUP = 64  # threads of a group-per-env task entry (env_group.hlsli)


class VectorEnv(gymnasium.vector.VectorEnv):
    """Base of the batched tasks. Subclasses build the scene (`build_world`), name their HLSL
    file and its three entry points, give their per-env spaces and fill the task constants."""

    # every task's frame is 1/60 s: render() gives 60 images a second of simulated time
    metadata = {"autoreset_mode": AutoresetMode.SAME_STEP, "render_modes": ["rgb_array"], "render_fps": 60}
    hlsl: Path  # task passes: `entries` (evaluate also as evaluate_reset_all)
    entries = ("apply_action", "evaluate", "observe")
    # entries that run a thread group an env (env_group.hlsli's ENV_GROUP threads) rather than a thread
    group_entries: tuple = ()
    single_observation_space: Box
    single_action_space: Box
    max_episode_steps: int
    # render_mode="rgb_array": the video camera's eye and target (m, z up) in each rendered env, or
    # (own_cameras) the task's own camera in every env is what render() shows
    video_view: tuple = ((0.0, -3.0, 2.0), (0.0, 0.0, 0.0))
    own_cameras = False
    scene_randomization: tuple = ()  # domain randomization terms of the scene file build_world loaded
    renders_cameras = False  # sense() renders the task's cameras (their depth noise goes on each new image)

    def __init__(self, num_envs: int, *, device: str | torch.device | None = None, seed: int = 0,
                 validation: bool | None = None, vulkan_device: str | None = None, cuda_sync: str = "semaphore",
                 final_observation: bool = True, render_mode: str | None = None, render_envs=(0,),
                 render_size: tuple = (320, 240), env_offset: int = 0, randomization=None):
        """`final_observation`: each step also observes every env before its reset (for
        `info["final_obs"]`); off, a step skips that observe pass and, in image tasks, a second
        render (learners that never read the final observation: `cressim train`, `cressim bench`).
        `render_mode="rgb_array"`: `render()` returns the images of the envs `render_envs` after
        each step, from a camera (`render_size`, width and height) added to those envs only, or
        from the task's own cameras. `env_offset`: where env 0 sits in a larger batch that this one
        is a shard of (one process's part under torch.distributed): env k draws the random numbers
        of env env_offset + k there, so the shards together run exactly the envs of the one large
        batch. `randomization`: domain randomization terms (a list of dicts, or a YAML file: a scene
        file's `randomization:` section or the list itself; docs/envs.md), drawn on the GPU per env
        at its reset or on an interval from the env's seed; `randomized(name)` gives the values."""
        name = type(self).__name__
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise ValueError(f"{name}: num_envs must be a positive integer, got {num_envs!r}")
        if isinstance(env_offset, bool) or not isinstance(env_offset, (int, np.integer)) or env_offset < 0:
            raise ValueError(f"{name}: env_offset must be an integer >= 0, got {env_offset!r}")
        if not isinstance(final_observation, bool):
            raise ValueError(f"{name}: final_observation must be True or False, got {final_observation!r}")
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"{name}: render_mode must be None or 'rgb_array', got {render_mode!r}")
        envs = list(render_envs) if isinstance(render_envs, (list, tuple, range)) else None
        if (not envs or len(set(envs)) != len(envs)
                or not all(isinstance(i, (int, np.integer)) and 0 <= i < num_envs for i in envs)):
            raise ValueError(f"{name}: render_envs must be distinct env indices in [0, {num_envs}), got {render_envs!r}")
        if (not isinstance(render_size, (list, tuple)) or len(render_size) != 2
                or not all(isinstance(v, (int, np.integer)) and 16 <= v <= 4096 and v % 2 == 0 for v in render_size)):
            raise ValueError(f"{name}: render_size must be (width, height), even integers in [16, 4096] "
                             f"(video frames), got {render_size!r}")
        self.num_envs, self.env_offset = int(num_envs), int(env_offset)
        self.final_observation = final_observation
        self.render_mode, self.render_envs, self.render_size = render_mode, [int(i) for i in envs], tuple(render_size)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        world = self.build_world(self.num_envs)
        if render_mode is not None and not self.own_cameras:
            self._add_video_cameras(world)
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
        self.randomizer = None
        # the scene file's randomization section (a task that loads one sets scene_randomization), then the task's
        terms = list(self.scene_randomization)
        if randomization is not None:
            terms += load_terms(randomization, f"{name}(randomization=...)")
        if terms:
            self.randomizer = Randomizer(self.engine, terms, seed=self.seed, env_offset=self.env_offset,
                                         episode_flags=self.episode_flags())
            if self.randomizer.sensor_noise and not self.renders_cameras:  # noise on a stale image would pile up
                raise ValueError(f"{name}: depth_noise needs a camera the task renders every step; {name} renders none")
        if self.device.type == "cuda":  # frames wait for the actions written on torch's stream
            if cuda_sync not in ("semaphore", "host"):
                raise ValueError(f"cuda_sync={cuda_sync!r}: use 'semaphore' (on the GPU) or 'host'")
            self.engine.set_cuda_stream(torch.cuda.current_stream(self.device).cuda_stream,
                                        host_sync=cuda_sync == "host")
        self.actions = tensor_view(self.buffers.actions, self.device)
        self.obs = tensor_view(self.buffers.observations, self.device)
        self.final_obs = tensor_view(self.buffers.final_observations, self.device) if final_observation else None
        self.reward = tensor_view(self.buffers.rewards, self.device)
        self.terminated = _bool_view(tensor_view(self.buffers.terminated, self.device))
        self.truncated = _bool_view(tensor_view(self.buffers.truncated, self.device))
        self.episode_length = tensor_view(self.buffers.episode_length, self.device)
        self.finished_length = tensor_view(self.buffers.finished_length, self.device)
        self.health = tensor_view(self.engine.buffer("env.health"), self.device).view(torch.int32)
        self._randomized = tensor_view(self.randomizer.values, self.device) if self.randomizer else None
        self._video = self._video_cameras() if render_mode is not None else []

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

    def episode_flags(self) -> tuple:
        """Buffers flagging the envs whose episode ended this step, for a task whose episodes
        start without the engine's reset (none: env.reset_mask tells the randomizer)."""
        return ()

    def sense(self) -> None:
        """Sensor stages the observation reads, recorded before `observe` (none by default)."""

    # --- the batched API ---------------------------------------------------------------------
    def default_device(self) -> torch.device:
        probe = self.engine.buffer("env.health")
        return torch.device("cpu") if probe.host_visible else torch.device("cuda", 0)

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Starts a new episode in every env; returns (obs, info). `seed` (an int) seeds every
        env's reset noise; `options` are not used (None)."""
        if options is not None:
            raise ValueError(f"{type(self).__name__}.reset: options are not used, got {options!r}")
        if seed is not None:
            if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= seed < 2 ** 32:
                raise ValueError(f"{type(self).__name__}.reset: seed must be an integer in [0, 2**32), got {seed!r}")
            if seed != self.seed:
                self.seed = int(seed)
                self._set_seed(self.seed)
        self._frame(reset_all=True)
        return self.obs, self._info()

    def step(self, actions):
        """Applies `actions` (num_envs, *single_action_space.shape; a tensor or an array) and
        advances one frame. Writing the actions into `env.actions` in place and passing that
        tensor saves the copy."""
        if not torch.is_tensor(actions):
            actions = torch.as_tensor(np.asarray(actions, np.float32))
        if actions.shape != self.actions.shape and actions.numel() != self.actions.numel():
            raise ValueError(f"{type(self).__name__}.step: actions of shape {tuple(actions.shape)}, expected "
                             f"{tuple(self.actions.shape)} (num_envs, *single_action_space.shape)")
        if actions.data_ptr() != self.actions.data_ptr():
            self.actions.copy_(actions.reshape(self.actions.shape))
        self._frame(reset_all=False)
        info = self._info()
        if self.final_obs is not None:  # gymnasium's SAME_STEP: finished envs' last obs and info
            done = self.terminated | self.truncated
            info.update(final_obs=self.final_obs, _final_obs=done, _final_info=done,
                        final_info={"episode_length": self.finished_length, "_episode_length": done})
        return self.obs, self.reward, self.terminated, self.truncated, info

    def render(self) -> np.ndarray | None:
        """With render_mode="rgb_array": the last step's images of `render_envs`, (envs, H, W, 3)
        uint8 on the host; else None."""
        if self.render_mode is None:
            return None
        return np.stack([image[..., :3].cpu().numpy() for image in self._video])

    def randomized(self, name: str | None = None) -> torch.Tensor:
        """The domain randomization values in use: (num_envs, components) of term `name` (its
        `name`, by default "<param>/<entity>"), or every term's side by side; a view that the
        next draw changes."""
        if self.randomizer is None:
            raise ValueError(f"{type(self).__name__}: no randomization configured (randomization=...)")
        return self._randomized if name is None else self._randomized[:, self.randomizer.columns(name)]

    def rendered(self, env: int) -> bool:
        """Whether env `env` is drawn for render() (a task gives its bodies visuals there)."""
        return self.render_mode is not None and env in self.render_envs

    def close_extras(self, **kwargs):
        self.engine = None
        self._video = []

    # --- internals ---------------------------------------------------------------------------
    def _info(self) -> dict:
        return {"episode_length": self.episode_length, "finished_length": self.finished_length,
                "health": self.health}

    def _add_video_cameras(self, world: cressim.World):
        """A camera (looking from video_view's eye at its target) and a light in each rendered env."""
        eye, target = self.video_view
        width, height = self.render_size
        for env in self.render_envs:
            camera = world.create_entity(env=env, name="video_camera")
            camera.add(cressim.Transform(position=eye, rotation=_quat_look_at(eye, target)))
            camera.add(cressim.Camera(width=width, height=height, fov_y=45.0, products=["rgb"]))
            light = world.create_entity(env=env, name="video_light")
            light.add(cressim.Transform(rotation=(0.2, 0.1, 0.0, 0.97)))  # mostly downwards
            light.add(cressim.Light(intensity=1.0, ambient=0.35))

    def _video_cameras(self) -> list:
        """Each rendered env's image, a view of its camera's layer (RGBA)."""
        cams = self.engine.cameras
        views = []
        for env in self.render_envs:
            rows = np.flatnonzero(cams["env"] == env)
            if not len(rows):
                raise RuntimeError(f"{type(self).__name__}: env {env} has no camera to render")
            group, layer = int(cams["group"][rows[0]]), int(cams["layer"][rows[0]])
            views.append(tensor_view(self.engine.buffer(f"camera{group}.rgb"), self.device)[layer])  # (H, W, 4) uint8
        return views

    def _sense(self):
        self.sense()
        if self.randomizer is not None:  # sensor noise, before the observation reads the images
            self.randomizer.after_sensors()

    def _set_seed(self, seed: int):
        for key in ("evaluate", "evaluate_reset_all"):
            self.passes[key].set_constant("seed", seed)
        if self.randomizer is not None:
            self.randomizer.set_seed(seed)

    def _create_buffers(self) -> TaskBuffers:
        # flags and counters are int32: torch's uint32 support on CUDA is partial
        n, e = self.num_envs, self.engine
        obs_shape, obs_dtype = (n, *self.single_observation_space.shape), str(self.single_observation_space.dtype)
        return TaskBuffers(
            actions=e.create_shared_buffer("actions", (n, *self.single_action_space.shape), "float32"),
            observations=e.create_shared_buffer("observations", obs_shape, obs_dtype),
            rewards=e.create_shared_buffer("rewards", n, "float32"),
            terminated=e.create_shared_buffer("terminated", n, "int32"),
            truncated=e.create_shared_buffer("truncated", n, "int32"),
            episode_length=e.create_shared_buffer("episode_length", n, "int32"),
            finished_length=e.create_shared_buffer("finished_length", n, "float32"),
            final_observations=e.create_shared_buffer("final_observations", obs_shape, obs_dtype)
            if self.final_observation else None)

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
        def threads(entry: str) -> int:
            return self.num_envs * (ENV_GROUP if entry in self.group_entries else 1)

        for entry in self.entries:
            if entry == "observe":
                passes["observe"], passes["observe_final"] = self.observe_passes(
                    source, entry, threads(entry), common, {**self.task_constants(reset_all=False), **shard})
                continue
            passes[entry] = self.engine.create_compute_pass(
                source, name=str(self.hlsl), entry=entry, threads=threads(entry),
                bindings={k: v for k, v in common.items() if k in declared},
                constants={**self.task_constants(reset_all=False), **shard})
        passes["evaluate_reset_all"] = self.engine.create_compute_pass(
            source, name=str(self.hlsl), entry="evaluate", threads=threads("evaluate"),
            bindings={k: v for k, v in common.items() if k in declared},
            constants={**self.task_constants(reset_all=True), **shard})
        return passes

    def observe_passes(self, source: str, entry: str, threads: int, bindings: dict, constants: dict,
                       name: str | None = None) -> tuple[list, list]:
        """The observe pass `entry` as ([the pass], [its final twin]): the twin runs the same code
        with `observations` bound to the final observations and, where the task declares them,
        the constant `final_obs` = 1 and `last_observations` = the last step's observations (a
        frame stack); no twin ([]) with final observations off."""
        declared = _declared(source)

        def create(out, final: bool):
            b = {**bindings, "observations": out, "last_observations": self.buffers.observations}
            c = {**constants, "final_obs": int(final)} if "final_obs" in declared else constants
            return self.engine.create_compute_pass(source, name=name or str(self.hlsl), entry=entry, threads=threads,
                                                   bindings={k: v for k, v in b.items() if k in declared},
                                                   constants=c)

        final = [create(self.buffers.final_observations, True)] if self.final_observation else []
        return [create(self.buffers.observations, False)], final

    def observe(self, final: bool = False) -> None:
        """Records the observe passes: into the observations, or (`final`) the final observations."""
        for observe in self.passes["observe_final" if final else "observe"]:
            self.engine.execute_compute_pass(observe)

    def _frame(self, reset_all: bool):
        self.record_step(reset_all)
        self.engine.end_frame()

    def record_step(self, reset_all: bool = False) -> None:
        """Records one env step into the frame being built, without submitting it: a caller that
        records several (with its own passes between them, e.g. a policy in the engine) runs
        them all in one submit at `engine.end_frame()`; `step()` is this and end_frame."""
        e, p = self.engine, self.passes
        if reset_all:  # no physics: flag and randomise every env, reset, observe
            e.execute_compute_pass(p["evaluate_reset_all"])
        else:
            self.act()
            e.step_physics()
            if self.final_observation:  # every env's observation before evaluate starts the next episodes
                self._sense()
                self.observe(final=True)
            e.execute_compute_pass(p["evaluate"])
        r = self.randomizer
        if r is not None:  # draws for the envs flagged to reset (and due intervals), written after the reset
            r.sample(reset_all)
        e.reset_flagged_envs()
        if r is not None:
            r.apply()
        self._sense()
        self.observe()
        if self.render_mode is not None and not self.own_cameras:  # the video cameras
            e.step_visual_sensors()


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
