"""Where a task's step goes: GPU milliseconds per frame op (timestamps around each recorded op:
the task's passes, physics, sensors, resets) beside the wall time of a step, for some env counts.

    PYTHONPATH=python python3 benchmarks/profile_task.py TissueRetract --envs 256,1024 [--json OUT]

--passes also times every compute pass inside the ops (Engine.profile_passes) and prints, per op,
the passes by total time with how often each ran a frame: what a stage's time is made of
(dispatch count against work per dispatch). The extra timestamps add a little GPU time.
"""
from __future__ import annotations

import argparse
import json
import time
from collections import defaultdict

import torch

import cressim.envs


def profile(task: str, envs: int, warmup: int, steps: int, solver: str | None = None, passes: bool = False) -> dict:
    env = cressim.envs.make(task, num_envs=envs, final_observation=False)  # the step the learners and benches run
    if solver:  # the particle solver's schedule (PhysicsSettings.particle_solver) instead of the task's
        physics = env.engine.physics
        physics.particle_solver = solver
        env.engine.physics = physics
    env.reset()
    cuda = env.device.type == "cuda"
    for _ in range(warmup):
        env.step(env.actions)
    if cuda:
        torch.cuda.synchronize()
    t0 = time.perf_counter()
    for _ in range(steps):
        env.step(env.actions)
        if cuda:
            torch.cuda.synchronize()
    wall_ms = (time.perf_counter() - t0) * 1e3 / steps
    env.engine.profiling = True
    env.engine.profile_passes = passes
    ops = defaultdict(float)
    per_pass = defaultdict(lambda: [0.0, 0])  # (op, pass): ms a frame, dispatches a frame
    for _ in range(steps):
        env.step(env.actions)
        for label, ms in env.engine.last_timings:
            ops[label] += ms / steps
        for op, name, ms in env.engine.last_pass_timings:
            per_pass[op, name][0] += ms / steps
            per_pass[op, name][1] += 1 / steps
    env.engine.profiling = False
    env.close()
    result = {"task": task, "envs": envs, "particle_solver": solver or "task's", "wall_ms_per_step": wall_ms,
              "env_steps_per_s": envs * 1e3 / wall_ms, "gpu_ms": dict(ops), "gpu_ms_total": sum(ops.values())}
    if passes:
        result["passes"] = [{"op": op, "pass": name, "ms": ms, "dispatches": round(count, 2)}
                            for (op, name), (ms, count) in sorted(per_pass.items(), key=lambda kv: -kv[1][0])]
    return result


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("task")
    parser.add_argument("--envs", default="256")
    parser.add_argument("--warmup", type=int, default=32)
    parser.add_argument("--steps", type=int, default=64)
    parser.add_argument("--json")
    parser.add_argument("--passes", action="store_true", help="time every compute pass inside the ops too")
    parser.add_argument("--particle-solvers", default="", help="comma-separated schedules to compare (auto, "
                        "dispatch, workgroup); default the task's")
    args = parser.parse_args()
    rows = []
    solvers = args.particle_solvers.split(",") if args.particle_solvers else [None]
    for n, solver in ((int(v), solver) for v in args.envs.split(",") for solver in solvers):
        r = profile(args.task, n, args.warmup, args.steps, solver, args.passes)
        rows.append(r)
        print(f"{args.task} {n} envs, solver {r['particle_solver']}: {r['wall_ms_per_step']:.3f} ms a step "
              f"({r['env_steps_per_s']:,.0f} env-steps/s), GPU {r['gpu_ms_total']:.3f} ms:")
        for label, ms in r["gpu_ms"].items():
            print(f"    {label:40s} {ms:8.3f} ms")
            for p in (p for p in r.get("passes", []) if p["op"] == label and p["ms"] >= 0.002):
                print(f"        {p['pass']:52s} {p['ms']:8.3f} ms  x{p['dispatches']:g}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
