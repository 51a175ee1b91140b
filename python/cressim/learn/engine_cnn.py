"""A torch CNN policy (TASKS.md's image actor, torch_ppo.ImageCNN) run inside the engine's frame,
reading the torch weights without copies.

As EnginePolicy does for MLPs: the actor's parameters and the Gaussian's log-std move into one
engine shared buffer (`policy_weights`) that the torch tensors then view, so the optimizer's
in-place steps are what the next frame reads. Each convolution and each hidden linear layer is
one `gemm` pass of engine_cnn.hlsl (an implicit matrix product, tiled for the GPU; its outputs in
an engine buffer of its own), and a `head` pass computes the last linear layer, draws the noise
(the MLP pass's per-env hash), writes the actions where the task's step reads them and stores the
observation, the action and its log-probability at the env's row of the rollout buffers.
"""
from __future__ import annotations

import math
from pathlib import Path

import torch
from torch import nn

from cressim.envs.vector_env import tensor_view

from .engine_policy import ACTIVATIONS, SHARED_BYTES, share_into
from .torch_ppo import ImageCNN

HLSL = Path(__file__).with_name("engine_cnn.hlsl")
NO_ACTIVATION = 3
THREADS = 256      # a gemm group's threads
HEAD_GROUP = 64    # a head group's threads (one env)
K_CHUNK = 16       # k values staged in groupshared memory at a time
# groups a layer should spread over: a few per streaming multiprocessor of a large GPU (an H100
# has 132), so that one layer's tiles keep it busy; only shapes the tiling, never the result
TARGET_GROUPS = 512


def cnn_layers(actor: nn.Module) -> list[dict]:
    """The actor's layers in order: {"kind": "conv" | "linear", "module", "act", "name"}, checked
    against what the passes compute; raises naming the first module they cannot run."""
    if not isinstance(actor, ImageCNN):
        raise ValueError(f"EngineCNNPolicy runs torch_ppo.ImageCNN actors (TASKS.md's CNN), got {type(actor).__name__}")
    layers, flat = [], False
    modules = [(f"convs.{i}", m) for i, m in enumerate(actor.convs)] + [(f"head.{i}", m) for i, m in enumerate(actor.head)]
    for name, m in modules:
        what = f"EngineCNNPolicy: layer {name} ({m})"
        if isinstance(m, nn.Conv2d):
            if flat:
                raise ValueError(f"{what} follows a Flatten or a Linear; convolutions come first")
            if (m.padding not in ((0, 0), "valid") or m.dilation != (1, 1) or m.groups != 1 or m.bias is None
                    or m.kernel_size[0] != m.kernel_size[1] or m.stride[0] != m.stride[1]):
                raise ValueError(f"{what}: the pass runs square kernels and strides with a bias, no padding, "
                                 f"dilation or groups")
            layers.append({"kind": "conv", "module": m, "act": NO_ACTIVATION, "name": name})
        elif isinstance(m, nn.Linear):
            if not flat and layers:
                raise ValueError(f"{what}: a Flatten must come between the convolutions and the linear layers")
            if m.bias is None:
                raise ValueError(f"{what}: the pass runs linear layers with a bias")
            flat = True
            layers.append({"kind": "linear", "module": m, "act": NO_ACTIVATION, "name": name})
        elif isinstance(m, nn.Flatten):
            if flat or not layers or (m.start_dim, m.end_dim) != (1, -1):
                raise ValueError(f"{what}: one Flatten(1, -1), right after the convolutions")
            flat = True
        elif type(m) in ACTIVATIONS and not (isinstance(m, nn.ELU) and m.alpha != 1.0):
            if not layers or layers[-1]["act"] != NO_ACTIVATION:
                raise ValueError(f"{what}: one activation after each convolution or linear layer")
            layers[-1]["act"] = ACTIVATIONS[type(m)]
        else:
            raise ValueError(f"{what} is not supported: the pass runs Conv2d, Linear, Flatten, ReLU, Tanh, ELU(1)")
    if not layers or layers[0]["kind"] != "conv":
        raise ValueError("EngineCNNPolicy: the actor must begin with a convolution")
    if layers[-1]["kind"] != "linear" or layers[-1]["act"] != NO_ACTIVATION:
        raise ValueError("EngineCNNPolicy: the actor must end in a Linear layer without an activation (the means)")
    return layers


def gemm_plan(rows: int, cols: int, k: int, linear: bool) -> dict:
    """Tiling of a (rows x k) by (k x cols) product for the gemm pass: threads TM x TN, each RM x RN
    outputs, and SPLIT groups along k (linear layers only: their rows are the envs, often too few
    for the GPU). Picks, in order: enough groups for TARGET_GROUPS, more outputs a thread (fewer
    groupshared reads a product), less padding."""
    best = None
    for rm, rn in ((4, 4), (4, 2), (2, 4), (2, 2), (2, 1), (1, 1)):
        for tn in (4, 8, 16, 32, 64):
            tm = THREADS // tn
            tile_m, tile_n = tm * rm, tn * rn
            if (tile_m + tile_n + 2) * K_CHUNK * 4 > SHARED_BYTES:
                continue
            groups = math.ceil(rows / tile_m) * math.ceil(cols / tile_n)
            padded = math.ceil(rows / tile_m) * tile_m * math.ceil(cols / tile_n) * tile_n / (rows * cols)
            key = (min(groups, TARGET_GROUPS), rm * rn, -padded)
            if best is None or key > best[0]:
                best = (key, dict(TM=tm, TN=tn, RM=rm, RN=rn, groups=(math.ceil(rows / tile_m), math.ceil(cols / tile_n))))
    plan = best[1]
    chunks, split = math.ceil(k / K_CHUNK), 1
    groups = plan["groups"][0] * plan["groups"][1]
    if linear and groups < TARGET_GROUPS // 2:
        split = max(1, min(chunks // 4, 32, TARGET_GROUPS // groups))
    per_split = math.ceil(chunks / split) * K_CHUNK
    plan.update(SPLIT=math.ceil(k / per_split), K_PER_SPLIT=per_split)
    return plan


class EngineCNNPolicy:
    """The Gaussian policy N(actor(obs), exp(log_std)) of a torch ImageCNN `actor` as engine passes
    over `env`'s envs; the interface of EnginePolicy (record, set_explore, obs, actions, log_prob,
    step_count, buffers, weights). Observations: the task's image, uint8 (scaled by 1/255 as the
    module does) or float32, (H, W, C) or (C, H, W) as the actor was built for."""

    def __init__(self, env, actor: nn.Module, log_std: torch.Tensor, *, rollout: int = 1, seed: int = 0,
                 explore: bool = True):
        obs_shape, act_shape = env.single_observation_space.shape, env.single_action_space.shape
        layers = cnn_layers(actor)
        if isinstance(rollout, bool) or not isinstance(rollout, int) or rollout < 1:
            raise ValueError(f"EngineCNNPolicy: rollout must be a positive integer, got {rollout!r}")
        dtype = env.obs.dtype
        if tuple(obs_shape) != actor.shape or dtype not in (torch.uint8, torch.float32) or len(act_shape) != 1:
            raise ValueError(f"EngineCNNPolicy: {type(env).__name__} has {dtype} observations of shape {obs_shape} and "
                             f"actions of shape {act_shape}; the actor takes images of shape {actor.shape} (uint8 or "
                             f"float32) and gives flat actions")
        num_actions, num_obs = act_shape[0], math.prod(obs_shape)
        if layers[-1]["module"].out_features != num_actions or tuple(log_std.shape) != (num_actions,):
            raise ValueError(f"EngineCNNPolicy: the actor gives {layers[-1]['module'].out_features} actions and log_std "
                             f"has shape {tuple(log_std.shape)}; {type(env).__name__} has {num_actions} actions")
        if dtype == torch.uint8 and num_obs % 4:
            raise ValueError(f"EngineCNNPolicy: uint8 images of {num_obs} bytes; the passes read whole 4-byte words")
        channels = obs_shape[-1] if actor.channels_last else obs_shape[0]
        height, width = (obs_shape[0], obs_shape[1]) if actor.channels_last else (obs_shape[1], obs_shape[2])
        self.env, self.actor, self.log_std, self.rollout = env, actor, log_std, rollout
        n, e, dev = env.num_envs, env.engine, env.device

        shared, offset = [], 0
        for layer in layers:
            m = layer["module"]
            layer["w_off"], layer["b_off"] = offset, offset + m.weight.numel()
            offset += m.weight.numel() + m.bias.numel()
            shared += [m.weight, m.bias]
        self.weights = share_into(e, "policy_weights", shared + [log_std], dev)
        obs_type = "uint8" if dtype == torch.uint8 else "float32"
        self.buffers = {
            "rollout_obs": e.create_shared_buffer("rollout_obs", (rollout, n, num_obs), obs_type),
            "rollout_actions": e.create_shared_buffer("rollout_actions", (rollout, n, num_actions), "float32"),
            "rollout_log_prob": e.create_shared_buffer("rollout_log_prob", (rollout, n), "float32"),
            "rollout_step": e.create_shared_buffer("rollout_step", n, "int32")}
        self.obs, self.actions, self.log_prob = (tensor_view(self.buffers[k], dev) for k in
                                                 ("rollout_obs", "rollout_actions", "rollout_log_prob"))
        self.step_count = tensor_view(self.buffers["rollout_step"], dev)  # uint in HLSL, far below 2**31
        constants = {"envs": n, "rollout": rollout, "seed": seed, "env_offset": env.env_offset, "explore": int(explore)}
        common = {"weights": "policy_weights", "observations": env.buffers.observations, **self.buffers}
        source = HLSL.read_text()

        # the layers but the last as gemm passes; `previous` describes what the next pass reads
        previous = dict(IN_SIZE=num_obs, SPLIT_IN=1, IN_BIAS=0, IN_ACT=NO_ACTIVATION)
        shape = (channels, height, width)
        self.passes, self.plans = [], []
        for i, layer in enumerate(layers[:-1]):
            m = layer["module"]
            if layer["kind"] == "conv":
                k, s = m.kernel_size[0], m.stride[0]
                out = (m.out_channels, (shape[1] - k) // s + 1, (shape[2] - k) // s + 1)
                if m.in_channels != shape[0] or min(out[1:]) < 1:
                    raise ValueError(f"EngineCNNPolicy: layer {layer['name']} ({m}) does not fit its input of "
                                     f"(channels, height, width) {shape}")
                geometry = dict(IN_C=shape[0], IN_H=shape[1], IN_W=shape[2], KSIZE=k, STRIDE=s,
                                OUT_C=out[0], OUT_H=out[1], OUT_W=out[2])
            else:
                if m.in_features != math.prod(shape):
                    raise ValueError(f"EngineCNNPolicy: layer {layer['name']} ({m}) takes {m.in_features} inputs, "
                                     f"its input has {math.prod(shape)}")
                out = (m.out_features, 1, 1)
                geometry = dict(IN_C=m.in_features, IN_H=1, IN_W=1, KSIZE=1, STRIDE=1, OUT_C=m.out_features,
                                OUT_H=1, OUT_W=1)
            plan = gemm_plan(n * out[1] * out[2], out[0], m.weight[0].numel(), layer["kind"] == "linear")
            self.plans.append(plan)
            defines = dict(FIRST=int(i == 0), OBS_UINT8=int(dtype == torch.uint8),
                           OBS_CHANNELS_LAST=int(actor.channels_last), **geometry, W_OFF=layer["w_off"],
                           B_OFF=layer["b_off"], ACT=layer["act"], K_CHUNK=K_CHUNK,
                           A_K_FASTEST=int(layer["kind"] == "linear"), **previous,
                           **{key: plan[key] for key in ("TM", "TN", "RM", "RN", "SPLIT", "K_PER_SPLIT")})
            scratch = e.create_shared_buffer(f"policy_layer{i}", (plan["SPLIT"], n, math.prod(out)), "float32")
            inputs = {"layer_in": f"policy_layer{i - 1}"} if i else {}
            self.passes.append(e.create_compute_pass(
                _header(defines) + source, name=str(HLSL), entry="gemm", dispatch=(*plan["groups"], plan["SPLIT"]),
                bindings={**common, **inputs, "layer_out": scratch}, constants=constants))
            previous = dict(IN_SIZE=math.prod(out), SPLIT_IN=plan["SPLIT"], IN_BIAS=layer["b_off"], IN_ACT=layer["act"])
            shape = out

        last = layers[-1]["module"]
        if last.in_features != previous["IN_SIZE"] or 4 * (previous["IN_SIZE"] + HEAD_GROUP * num_actions) > SHARED_BYTES:
            raise ValueError(f"EngineCNNPolicy: layer {layers[-1]['name']} ({last}) takes {last.in_features} inputs, "
                             f"its input has {previous['IN_SIZE']} (the head pass holds up to "
                             f"{SHARED_BYTES // 4 - HEAD_GROUP * num_actions})")
        defines = dict(HEAD_GROUP=HEAD_GROUP, OBS_UINT8=int(dtype == torch.uint8),
                       OBS_WORDS=num_obs // 4 if dtype == torch.uint8 else num_obs, ACTIONS=num_actions,
                       W_OFF=layers[-1]["w_off"], B_OFF=layers[-1]["b_off"], LOG_STD=offset, **previous)
        inputs = {"layer_in": f"policy_layer{len(layers) - 2}"} if len(layers) > 1 else {}
        self.passes.append(e.create_compute_pass(
            _header(defines) + source, name=str(HLSL), entry="head", dispatch=(n, 1, 1),
            bindings={**common, **inputs, "actions": env.buffers.actions}, constants=constants))

    def set_explore(self, explore: bool) -> None:
        self.passes[-1].set_constant("explore", int(bool(explore)))

    def record(self) -> None:
        """Adds the policy step (its passes, in order) to the frame being recorded."""
        for p in self.passes:
            self.env.engine.execute_compute_pass(p)


def _header(defines: dict) -> str:
    return "".join(f"#define {k} {v}\n" for k, v in defines.items()) + "#line 1\n"
