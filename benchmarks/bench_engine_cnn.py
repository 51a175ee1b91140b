"""TargetCenter (or another CNN task) with TASKS.md's CNN actor in the engine: env-steps/s with K
steps a submit (render -> CNN -> action -> step -> store, all recorded), and the GPU time of each
pass of a step (the CNN's layers, the task's ops), for some env counts.

    PYTHONPATH=python python3 benchmarks/bench_engine_cnn.py --envs 32,256,1024 --json OUT

Throughput as `cressim bench --mode policy` measures policy_engine_sps (no learning; the frame
returns once its GPU work is done), for each K in --steps-per-submit. `cnn_ms`: the CNN's passes
alone, K of them a frame with nothing else (the same images each time). The profiled frames put
GPU timestamps around every op, which adds a little GPU time.
"""
from __future__ import annotations

import argparse
import json
import math
import time
from collections import defaultdict

import torch

import cressim.envs
from cressim.learn import engine_cnn, ppo_config
from cressim.learn.engine_rollout import EngineRollout
from cressim.learn.rollout import sync
from cressim.learn.torch_ppo import TorchPPO


def short(label: str) -> str:
    return label.split("/")[-1].rstrip("'")


def measure(task: str, envs: int, ks: list, frames: int) -> dict:
    torch.manual_seed(0)
    env = cressim.envs.make(task, num_envs=envs, final_observation=False)
    shape = env.single_observation_space.shape
    rollout = math.lcm(*ks)
    alg = TorchPPO(math.prod(shape), env.single_action_space.shape[0], envs, ppo_config(task, rollout=rollout),
                   env.device, shape, env.obs.dtype)
    r = EngineRollout(env, alg, steps_per_submit=rollout)
    out = {"task": task, "envs": envs, "plans": r.policy.plans, "vulkan_device": env.engine.device["name"],
           "env_steps_per_s": {}}
    e = env.engine
    for k in ks:
        n = 2 + max(1, frames * max(ks) // k)
        for _ in range(2):
            r.record_steps(k)
            e.end_frame()
        sync(env.device)
        t0 = time.perf_counter()
        for _ in range(n - 2):
            r.record_steps(k)
            e.end_frame()
        sync(env.device)
        out["env_steps_per_s"][k] = (n - 2) * k * envs / (time.perf_counter() - t0)
        print(f"{task} {envs} envs, {k} steps a submit: {out['env_steps_per_s'][k]:,.0f} env-steps/s", flush=True)

    k = max(ks)
    e.profiling = True  # GPU timestamps around each recorded op (each pass, the physics, the render)
    r.record_steps(k)
    e.end_frame()
    per_op = defaultdict(float)
    for label, ms in e.last_timings:
        per_op[label] += ms / k
    out["gpu_ms_per_step"] = dict(sorted(per_op.items(), key=lambda kv: -kv[1]))
    out["gpu_ms_per_step_total"] = sum(per_op.values())
    for _ in range(k):  # the CNN alone
        r.policy.record()
    e.end_frame()
    cnn = defaultdict(float)
    for label, ms in e.last_timings:
        if str(engine_cnn.HLSL) in label:
            cnn[label] += ms / k
    out["cnn_ms"] = dict(cnn)
    e.profiling = False
    print(f"  GPU per step {out['gpu_ms_per_step_total']:.4f} ms; the CNN's passes alone:")
    for name, ms in out["cnn_ms"].items():
        print(f"    {short(name):40s} {ms:8.4f} ms")
    print("  a step's ops:")
    for name, ms in out["gpu_ms_per_step"].items():
        print(f"    {short(name):40s} {ms:8.4f} ms")
    env.close()
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("task", nargs="?", default="TargetCenter")
    parser.add_argument("--envs", default="32,256,1024")
    parser.add_argument("--steps-per-submit", default="1,8,32,128")
    parser.add_argument("--frames", type=int, default=4, help="frames of the largest K measured (more for smaller K)")
    parser.add_argument("--json")
    args = parser.parse_args()
    ks = [int(v) for v in args.steps_per_submit.split(",")]
    rows = [measure(args.task, int(n), ks, args.frames) for n in args.envs.split(",")]
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
