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

from .engine_policy import ACTIVATIONS, SHARED_BYTES, rollout_buffers, share_into
from .torch_ppo import ImageCNN

HLSL = Path(__file__).with_name("engine_cnn.hlsl")
NO_ACTIVATION = 3
HEAD_GROUP = 64    # a head group's threads (one env)
K_CHUNK = 16       # k values staged in groupshared memory at a time
# A rough model of a large GPU for choosing tiles (an H100: 132 multiprocessors, each issuing 4
# warp instructions of multiply-adds and one 128-byte groupshared read a clock, ~16 loads from
# cache a clock, ~600 clocks from memory); it only shapes the tiling, never the result.
SMS, FMA_ISSUE, SHARED_ISSUE, LOAD_RATE, LATENCY, BARRIER = 132, 4, 1, 16, 600, 40


def cnn_layers(actor: nn.Module) -> list[dict]:
    """The actor's layers in order: {"kind": "conv" | "linear", "module", "act", "name"}, checked
    against what the passes compute; raises naming the first module they cannot run."""
    if not isinstance(actor, ImageCNN):
        raise ValueError(f"EngineCNNPolicy runs torch_ppo.ImageCNN actors (TASKS.md's CNN), got {type(actor).__name__}")
    layers, flat = [], False
    modules = [(f"{part}.{i}", m) for part in ("convs", "head") for i, m in enumerate(getattr(actor, part))]
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


def gemm_plan(rows: int, cols: int, k: int, consumer_reads: int, max_groups=(65535, 65535, 65535)) -> dict:
    """Tiling of a (rows x k) by (k x cols) product for the gemm pass: TM x TN threads, each 4 x 4
    outputs, and SPLIT groups along k (partial sums the next pass adds up as it reads them, its
    `consumer_reads` values: worth it where the tiles are too few to fill the GPU, as a linear
    layer's over few envs). The plan of least modelled time (the module's constants): per k, a
    warp's float4 reads of groupshared memory against its 16 multiply-adds a thread, the groups
    each multiprocessor runs, memory latency hidden by prefetching one chunk ahead. `max_groups`:
    the device's maxComputeWorkGroupCount."""
    best = None
    chunks = math.ceil(k / K_CHUNK)
    for threads in (256, 128, 64):
        for tn in (4, 8, 16, 32, 64):
            tm = threads // tn
            tile_m, tile_n = 4 * tm, 4 * tn
            if (tile_m + tile_n + 8) * K_CHUNK * 4 > SHARED_BYTES:
                continue
            grid = (math.ceil(rows / tile_m), math.ceil(cols / tile_n))
            if grid[0] > max_groups[0] or grid[1] > max_groups[1]:
                continue
            warps = max(1, threads // 32)
            rows_a_warp = min(tm, 32)  # distinct float4 rows a warp reads a k; the rest share columns
            shared = warps * (math.ceil(16 * rows_a_warp / 128) + math.ceil(16 * (32 // rows_a_warp) / 128))
            compute = (K_CHUNK * max(warps * 16 / FMA_ISSUE, shared / SHARED_ISSUE)
                       + (tile_m + tile_n) * K_CHUNK / LOAD_RATE)
            for parts in (1, 2, 4, 8, 16, 32):
                per_split = math.ceil(chunks / parts)
                split = math.ceil(chunks / per_split)  # no empty parts
                if split > max_groups[2]:
                    continue
                per_sm = math.ceil(grid[0] * grid[1] * split / SMS)
                time = (per_split * (max(per_sm * compute, LATENCY) + BARRIER)
                        + (split - 1) * (consumer_reads + rows * cols) / (SMS * LOAD_RATE))
                if best is None or time < best[0]:
                    best = (time, dict(TM=tm, TN=tn, SPLIT=split, K_PER_SPLIT=per_split * K_CHUNK, groups=grid,
                                       modelled_clocks=round(time)))
    if best is None:
        raise ValueError(f"EngineCNNPolicy: a layer's {rows} x {cols} outputs need more workgroups than the device "
                         f"dispatches ({max_groups}); use fewer envs")
    return best[1]


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
            raise ValueError(f"EngineCNNPolicy: the actor gives {layers[-1]['module'].out_features} actions, log_std "
                             f"has shape {tuple(log_std.shape)}; {type(env).__name__} has {num_actions} actions")
        if dtype == torch.uint8 and num_obs % 4:
            raise ValueError(f"EngineCNNPolicy: uint8 images of {num_obs} bytes; the passes read whole 4-byte words")
        channels = obs_shape[-1] if actor.channels_last else obs_shape[0]
        height, width = (obs_shape[0], obs_shape[1]) if actor.channels_last else (obs_shape[1], obs_shape[2])
        # each layer's input and output (channels, height, width) and its product's k, checked
        # before the weights move
        shape = (channels, height, width)
        for layer in layers:
            m = layer["module"]
            if layer["kind"] == "conv":
                k, s = m.kernel_size[0], m.stride[0]
                out = (m.out_channels, (shape[1] - k) // s + 1, (shape[2] - k) // s + 1)
                if m.in_channels != shape[0] or min(out[1:]) < 1:
                    raise ValueError(f"EngineCNNPolicy: layer {layer['name']} ({m}) does not fit its input of "
                                     f"(channels, height, width) {shape}")
            else:
                if m.in_features != math.prod(shape):
                    raise ValueError(f"EngineCNNPolicy: layer {layer['name']} ({m}) takes {m.in_features} inputs, "
                                     f"its input has {math.prod(shape)}")
                out = (m.out_features, 1, 1)
            layer.update(shape_in=shape, shape_out=out, k=m.weight[0].numel())
            shape = out
        last = layers[-1]["module"]
        if 4 * (last.in_features + HEAD_GROUP * num_actions) > SHARED_BYTES:
            raise ValueError(f"EngineCNNPolicy: layer {layers[-1]['name']} ({last}) takes {last.in_features} inputs; "
                             f"the head pass holds up to {SHARED_BYTES // 4 - HEAD_GROUP * num_actions}")
        self.env, self.actor, self.log_std, self.rollout = env, actor, log_std, rollout
        n, e, dev = env.num_envs, env.engine, env.device

        shared, offset = [], 0
        for layer in layers:
            m = layer["module"]
            layer["w_off"], layer["b_off"] = offset, offset + m.weight.numel()
            offset += m.weight.numel() + m.bias.numel()
            shared += [m.weight, m.bias]
        self.weights = share_into(e, "policy_weights", shared + [log_std], dev)
        rollout_buffers(self, e, rollout, n, num_obs, num_actions, "uint8" if dtype == torch.uint8 else "float32", dev)
        constants = {"envs": n, "rollout": rollout, "seed": seed, "env_offset": env.env_offset, "explore": int(explore)}
        common = {"weights": "policy_weights", "observations": env.buffers.observations, **self.buffers}
        source = HLSL.read_text()  # a pass is named by the file and its layer: errors and pass timings say which

        # the layers but the last as gemm passes (each plan knows what its consumer reads);
        # `previous`: what the next pass reads (the observations, or a layer's outputs as stored)
        previous = dict(IN_SIZE=num_obs, SPLIT_IN=1, IN_BIAS=0, IN_ACT=NO_ACTIVATION, IN_PLANE=1)
        self.passes, self.plans = [], []
        for i, (layer, consumer) in enumerate(zip(layers, layers[1:])):
            (c, h, w), out = layer["shape_in"], layer["shape_out"]
            m = layer["module"]
            kernel, stride = (m.kernel_size[0], m.stride[0]) if layer["kind"] == "conv" else (1, 1)
            if layer["kind"] == "linear":
                c, h, w = c * h * w, 1, 1
            # the consumer reads its inputs once a tile of its columns (64 or so wide)
            reads = math.prod((n, *consumer["shape_out"][1:], consumer["k"], math.ceil(consumer["shape_out"][0] / 64)))
            plan = gemm_plan(n * out[1] * out[2], out[0], layer["k"], reads, e.device["max_compute_work_group_count"])
            self.plans.append(plan)
            defines = dict(FIRST=int(i == 0), OBS_UINT8=int(dtype == torch.uint8),
                           OBS_CHANNELS_LAST=int(actor.channels_last), IN_C=c, IN_H=h, IN_W=w, KSIZE=kernel,
                           STRIDE=stride, OUT_C=out[0], OUT_H=out[1], OUT_W=out[2], W_OFF=layer["w_off"],
                           B_OFF=layer["b_off"], ACT=layer["act"], K_CHUNK=K_CHUNK,
                           A_K_FASTEST=int(layer["kind"] == "linear"), **previous,
                           **{key: plan[key] for key in ("TM", "TN", "SPLIT", "K_PER_SPLIT")})
            scratch = e.create_shared_buffer(f"policy_layer{i}", (plan["SPLIT"], n, math.prod(out)), "float32")
            inputs = {"layer_in": f"policy_layer{i - 1}"} if i else {}
            self.passes.append(e.create_compute_pass(
                _header(defines) + source, name=f"{HLSL}[{layer['name']}]", entry="gemm",
                dispatch=(*plan["groups"], plan["SPLIT"]),
                bindings={**common, **inputs, "layer_out": scratch}, constants=constants))
            previous = dict(IN_SIZE=math.prod(out), SPLIT_IN=plan["SPLIT"], IN_BIAS=layer["b_off"], IN_ACT=layer["act"],
                            IN_PLANE=out[1] * out[2])

        defines = dict(HEAD_GROUP=HEAD_GROUP, OBS_UINT8=int(dtype == torch.uint8),
                       OBS_WORDS=num_obs // 4 if dtype == torch.uint8 else num_obs, ACTIONS=num_actions,
                       W_OFF=layers[-1]["w_off"], B_OFF=layers[-1]["b_off"], LOG_STD=offset, **previous)
        self.passes.append(e.create_compute_pass(
            _header(defines) + source, name=f"{HLSL}[{layers[-1]['name']}]", entry="head", dispatch=(n, 1, 1),
            bindings={**common, "layer_in": f"policy_layer{len(layers) - 2}", "actions": env.buffers.actions},
            constants=constants))

    def set_explore(self, explore: bool) -> None:
        self.passes[-1].set_constant("explore", int(bool(explore)))

    def record(self) -> None:
        """Adds the policy step (its passes, in order) to the frame being recorded."""
        for p in self.passes:
            self.env.engine.execute_compute_pass(p)


def _header(defines: dict) -> str:
    return "".join(f"#define {k} {v}\n" for k, v in defines.items()) + "#line 1\n"
