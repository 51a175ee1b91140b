"""What the CUDA -> Vulkan hand-off between two env steps costs, and what bounds it (GPU machine).

Every variant steps CartPole (8192 envs by default) with zero actions and reports env-steps/s
and the wall time per step; they differ only in what CUDA does between the frames and how the
frame is ordered after it:

  inplace          no CUDA work between frames (the simulator alone)
  copy_semaphore   actions copied by a CUDA kernel; the frame waits on the GPU for a timeline
                   semaphore that CUDA signals after the copy (env.step's default)
  copy_host        the same copy; the host waits for the CUDA stream, then submits (no semaphore)
  copy_synced      the same copy, torch.cuda.synchronize() before the step: the semaphore is
                   already signalled when the frame is submitted (its wait is free)
  copy_graph       the copy replayed as a CUDA graph (one launch), semaphore ordering
  kernel_unordered a CUDA kernel on a stream the frame does not wait on (no semaphore, no host
                   wait, the actions written in place): CUDA work merely happening beside Vulkan
  engine_k         the actor in the engine, k steps per submit (EngineRollout), no CUDA between

If copy_synced and kernel_unordered cost as much as copy_semaphore, the price is the GPU
switching between the CUDA and the Vulkan context (time-sliced channels), not the semaphore
or its signalling; only keeping CUDA off the GPU between frames (engine_k) removes it.

    PYTHONPATH=python python3 benchmarks/bench_handoff.py --envs 8192 --json "$OUT/handoff.json"
"""
from __future__ import annotations

import argparse
import json
import time

import torch

import cressim.envs
from cressim.learn.config import ppo_config
from cressim.learn.engine_rollout import EngineRollout
from cressim.learn.torch_ppo import TorchPPO


def measure(step, n: int, warmup: int, steps: int) -> dict:
    for _ in range(warmup):
        step()
    torch.cuda.synchronize()
    t0 = time.perf_counter()
    for _ in range(steps):
        step()
    torch.cuda.synchronize()
    dt = time.perf_counter() - t0
    return {"sps": steps * n / dt, "ms_per_step": 1e3 * dt / steps}


HANDOFFS = ("inplace", "copy_semaphore", "copy_host", "copy_synced", "copy_graph", "kernel_unordered")


def variants(n: int, warmup: int, steps: int, handoffs=HANDOFFS, submits=(1, 8, 128)) -> dict:
    out = {}
    for name in handoffs:
        env = cressim.envs.make("CartPole", num_envs=n, final_observation=False,
                                cuda_sync="host" if name == "copy_host" else "semaphore")
        env.reset()
        zeros = torch.zeros_like(env.actions)
        if name == "inplace":
            env.actions.zero_()
            step = lambda: env.step(env.actions)  # noqa: E731
        elif name == "copy_synced":
            def step():
                env.actions.copy_(zeros)
                torch.cuda.synchronize()
                env.step(env.actions)
        elif name == "copy_graph":
            graph = torch.cuda.CUDAGraph()
            side = torch.cuda.Stream()
            with torch.cuda.stream(side):
                env.actions.copy_(zeros)
                with torch.cuda.graph(graph, stream=side):
                    env.actions.copy_(zeros)
            torch.cuda.synchronize()

            def step():
                graph.replay()
                env.step(env.actions)
        elif name == "kernel_unordered":
            env.engine.set_cuda_stream(0)  # frames no longer wait for torch's stream
            side, scratch = torch.cuda.Stream(), torch.zeros(n, device=env.device)

            def step():
                with torch.cuda.stream(side):
                    scratch.add_(1.0)
                env.step(env.actions)
        else:
            step = lambda: env.step(zeros)  # noqa: E731
        out[name] = measure(step, n, warmup, steps)
        r = out[name]
        print(f"{name:>17}: {r['sps']:>14,.0f} env-steps/s, {r['ms_per_step']:.3f} ms a step", flush=True)
        env.close()
    for k in submits:
        env = cressim.envs.make("CartPole", num_envs=n, final_observation=False)
        alg = TorchPPO(4, 1, n, ppo_config("CartPole", rollout=128), env.device)
        rollout = EngineRollout(env, alg, steps_per_submit=k)

        def frame():
            rollout.record_steps(k)
            env.engine.end_frame()

        r = measure(frame, n * k, max(1, warmup // k), max(1, steps // k))
        out[f"engine_{k}"] = {"sps": r["sps"], "ms_per_step": r["ms_per_step"] / k}
        print(f"{'engine_' + str(k):>17}: {r['sps']:>14,.0f} env-steps/s, {r['ms_per_step'] / k:.3f} ms a step "
              f"(policy in the loop)", flush=True)
        if k == 8:  # GPU time of a step's parts, from the frame's timestamps
            env.engine.profiling = True
            frame()
            frame()
            parts = {}
            for label, ms in env.engine.last_timings:
                part = ("policy pass" if "engine_policy" in label else "store pass" if "engine_rollout" in label
                        else "task step")
                parts[part] = parts.get(part, 0.0) + ms / k
            env.engine.profiling = False
            out["gpu_ms_per_step"] = parts
            print("     GPU ms a step: " + ", ".join(f"{p} {ms:.4f}" for p, ms in parts.items()), flush=True)
        env.close()
    # the policy pass's GPU time a step by envs a group (TASKS.md's actor, 2 x 128 tanh)
    for tile in (2, 4, 8, 16):
        env = cressim.envs.make("CartPole", num_envs=n, final_observation=False)
        alg = TorchPPO(4, 1, n, ppo_config("CartPole", rollout=128), env.device)
        rollout = EngineRollout(env, alg, steps_per_submit=8, max_tile=tile)
        env.engine.profiling = True
        for _ in range(2):
            rollout.record_steps(8)
            env.engine.end_frame()
        ms = sum(t for label, t in env.engine.last_timings if "engine_policy" in label) / 8
        out[f"policy_pass_ms_tile{tile}"] = ms
        print(f"  policy pass, {tile:>2} envs a group: {ms:.4f} GPU ms a step", flush=True)
        env.close()
    return out


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--envs", type=int, default=8192)
    p.add_argument("--warmup", type=int, default=64)
    p.add_argument("--steps", type=int, default=512)
    p.add_argument("--json", help="write the results here")
    args = p.parse_args()
    if not torch.cuda.is_available():
        raise SystemExit("bench_handoff.py measures hand-offs between CUDA and Vulkan: it needs an NVIDIA GPU")
    result = {"device": torch.cuda.get_device_name(), "envs": args.envs, "steps": args.steps,
              "variants": variants(args.envs, args.warmup, args.steps)}
    if args.json:
        with open(args.json, "w") as f:
            json.dump(result, f, indent=1)


if __name__ == "__main__":
    main()
