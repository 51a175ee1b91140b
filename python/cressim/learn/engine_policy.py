"""A torch MLP policy run inside the engine's frame, reading the torch weights without copies.

The actor's parameters (and its observation normaliser's statistics, and the Gaussian's
log-std) are moved into one engine shared buffer and the torch tensors become views of it:
the optimizer updates them in place and the next frame's policy pass reads the new values, with
no copy and no call. The pass (engine_policy.hlsl) computes the MLP forward for every env,
draws the exploration noise from a hash of (seed, env in the whole batch, the env's step count,
action index), writes the actions where the task's apply_action reads them, and stores the
observation, the action and its log-probability at the env's row of the rollout buffers (views
for the learner). Any task whose observations and actions are flat float32 vectors can use it.
"""
from __future__ import annotations

import math
from pathlib import Path

import torch
from torch import nn

from cressim.envs.vector_env import tensor_view

HLSL = Path(__file__).with_name("engine_policy.hlsl")
ACTIVATIONS = {nn.Tanh: 0, nn.ELU: 1, nn.ReLU: 2}
SHARED_BYTES = 16384  # groupshared memory every Vulkan device has (maxComputeSharedMemorySize's minimum)
MAX_TILE = 16         # envs a group computes together, at most


def mlp_layers(actor: nn.Module) -> tuple:
    """(normalizer or None, [Linear ...], activation code) of an actor built as
    [Normalized(ObsNormalizer,)] Sequential(Linear, act, ..., Linear), one activation kind."""
    normalizer = getattr(actor, "normalizer", None)
    net = actor.net if normalizer is not None else actor
    modules = list(net) if isinstance(net, nn.Sequential) else []
    linears = modules[0::2]
    acts = {type(m) for m in modules[1::2]}
    ok = (modules and all(isinstance(m, nn.Linear) for m in linears) and len(modules) % 2 == 1
          and acts <= set(ACTIVATIONS) and len(acts) <= 1
          and all(a.out_features == b.in_features for a, b in zip(linears, linears[1:]))
          and not any(isinstance(m, nn.ELU) and m.alpha != 1.0 for m in modules))
    if not ok:
        raise ValueError(f"EnginePolicy runs MLPs: Sequential(Linear, Tanh|ELU|ReLU, ..., Linear), optionally "
                         f"Normalized; got {actor}")
    return normalizer, linears, ACTIVATIONS[acts.pop()] if acts else 0


def share_into(engine, name: str, tensors: list, device: torch.device) -> torch.Tensor:
    """Moves `tensors` (parameters or module buffers) into one engine shared buffer `name`, in
    order, each becoming a view of its slice (same object: optimizers and modules keep it);
    returns the flat view."""
    flat = tensor_view(engine.create_shared_buffer(name, sum(t.numel() for t in tensors), "float32"), device)
    offset = 0
    with torch.no_grad():
        for t in tensors:
            if t.dtype != torch.float32 or t.device != device:
                raise ValueError(f"share_into({name!r}): tensors must be float32 on {device}, "
                                 f"got {t.dtype} on {t.device}")
            view = flat[offset:offset + t.numel()].view(t.shape)
            view.copy_(t)
            t.data = view
            offset += t.numel()
    return flat


def rollout_buffers(policy, engine, rollout: int, n: int, num_obs: int, num_actions: int, obs_type: str,
                    device) -> None:
    """The rollout storage a policy pass writes (engine buffers: observations, actions, log-probs,
    each env's step), as `policy.buffers` and the learner's views `policy.obs`, `.actions`,
    `.log_prob` and `.step_count`."""
    policy.buffers = {
        "rollout_obs": engine.create_shared_buffer("rollout_obs", (rollout, n, num_obs), obs_type),
        "rollout_actions": engine.create_shared_buffer("rollout_actions", (rollout, n, num_actions), "float32"),
        "rollout_log_prob": engine.create_shared_buffer("rollout_log_prob", (rollout, n), "float32"),
        "rollout_step": engine.create_shared_buffer("rollout_step", n, "int32")}
    policy.obs, policy.actions, policy.log_prob = (tensor_view(policy.buffers[k], device) for k in
                                                   ("rollout_obs", "rollout_actions", "rollout_log_prob"))
    policy.step_count = tensor_view(policy.buffers["rollout_step"], device)  # uint in HLSL, far below 2**31


class EnginePolicy:
    """The Gaussian policy N(actor(obs), exp(log_std)) of a torch `actor` (an MLP) as an engine
    pass over `env`'s envs. `record()` adds one policy step to the frame being recorded (before
    the task's step): it reads env.obs, writes env.actions and row t % rollout of `obs`,
    `actions`, `log_prob` (rollout, num_envs, ...) where t is the env's `step_count`, which the
    caller advances after the task's step (EngineRollout's store pass). `explore=False` writes
    the mean actions. A group computes up to `max_tile` envs (fewer for wide layers): more reuse
    of each weight read, fewer groups in flight. The actor and log_std must live on env.device; their tensors become views
    of the engine buffer `policy_weights`."""

    def __init__(self, env, actor: nn.Module, log_std: torch.Tensor, *, rollout: int = 1, seed: int = 0,
                 explore: bool = True, max_tile: int = MAX_TILE):
        obs_shape, act_shape = env.single_observation_space.shape, env.single_action_space.shape
        if env.obs.dtype != torch.float32 or len(act_shape) != 1:
            raise ValueError(f"EnginePolicy: {type(env).__name__} has {env.obs.dtype} observations of shape "
                             f"{obs_shape} and actions of shape {act_shape}; the engine pass takes flat float32 vectors")
        if isinstance(rollout, bool) or not isinstance(rollout, int) or rollout < 1:
            raise ValueError(f"EnginePolicy: rollout must be a positive integer, got {rollout!r}")
        normalizer, linears, activation = mlp_layers(actor)
        num_obs, num_actions = math.prod(obs_shape), act_shape[0]
        widths = [linears[0].in_features] + [m.out_features for m in linears]
        if widths[0] != num_obs or widths[-1] != num_actions or tuple(log_std.shape) != (num_actions,):
            raise ValueError(f"EnginePolicy: the actor maps {widths[0]} -> {widths[-1]} values and log_std has shape "
                             f"{tuple(log_std.shape)}; {type(env).__name__} has {num_obs} observations and "
                             f"{num_actions} actions")
        widest = max(widths)
        if max_tile not in (1, 2, 4, 8, 16):
            raise ValueError(f"EnginePolicy: max_tile must be 1, 2, 4, 8 or 16, got {max_tile!r}")
        tile = max_tile
        while tile > 1 and 2 * tile * widest * 4 > SHARED_BYTES:
            tile //= 2
        if 2 * tile * widest * 4 > SHARED_BYTES:
            raise ValueError(f"EnginePolicy: a layer of {widest} units is wider than the pass holds "
                             f"({SHARED_BYTES // 8} units)")
        self.env, self.actor, self.log_std, self.rollout = env, actor, log_std, rollout
        self.widths, self.activation, self.env_tile = widths, activation, tile
        n, e, dev = env.num_envs, env.engine, env.device
        shared = ([normalizer.mean, normalizer.var] if normalizer is not None else [])
        for m in linears:
            shared += [m.weight, m.bias]
        self.weights = share_into(e, "policy_weights", shared + [log_std], dev)
        rollout_buffers(self, e, rollout, n, num_obs, num_actions, "float32", dev)
        header = "\n".join([
            f"#define ACTIVATION {activation}", f"#define NORMALIZED {int(normalizer is not None)}",
            f"static const uint OBS = {num_obs};", f"static const uint ACTIONS = {num_actions};",
            f"static const uint LAYERS = {len(linears)};",
            f"static const uint WIDTHS[{len(widths)}] = {{{', '.join(map(str, widths))}}};",
            f"static const uint MAX_WIDTH = {widest};", f"static const uint ENV_TILE = {tile};", "#line 1", ""])
        self.pass_ = e.create_compute_pass(
            header + HLSL.read_text(), name=str(HLSL), entry="act", dispatch=(-(-n // tile), 1, 1),
            bindings={"weights": "policy_weights", "observations": env.buffers.observations,
                      "actions": env.buffers.actions, **self.buffers},
            constants={"envs": n, "rollout": rollout, "seed": seed, "env_offset": env.env_offset,
                       "explore": int(explore)})

    def set_explore(self, explore: bool) -> None:
        self.pass_.set_constant("explore", int(bool(explore)))

    def record(self) -> None:
        """Adds the policy step to the frame being recorded."""
        self.env.engine.execute_compute_pass(self.pass_)
