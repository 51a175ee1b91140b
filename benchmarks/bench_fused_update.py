"""How long one PPO update takes, torch's (CUDA graphs per minibatch) against the fused Triton
update (learn/fused_update.py) in each of its kernel settings, on random rollouts of a task's
sizes (TASKS.md's network and minibatch; CartPole: 4 observations, 1 action, MLP 128, 2,048 a
minibatch). Prints ms an update and env-steps/s of learning alone (samples / update time), and
the GPU time of each kernel in one update (torch.profiler).

    PYTHONPATH=python python3 benchmarks/bench_fused_update.py --envs 8192 --json out.json
"""
import argparse
import itertools
import json
import time

import torch

from cressim.learn.config import ppo_config
from cressim.learn.fused_update import FusedUpdate
from cressim.learn.torch_ppo import TorchPPO

SIZES = {"CartPole": (4, 1), "SoftBodyPush": (17, 3), "FluidPour": (15, 2)}  # observations, actions


DEVICE = "cuda"


def learner(task: str, envs: int, fused: str) -> TorchPPO:
    torch.manual_seed(0)
    obs, act = SIZES[task]
    alg = TorchPPO(obs, act, envs, ppo_config(task, fused_update=fused), DEVICE)
    g = torch.Generator(device=DEVICE).manual_seed(1)
    with torch.no_grad():
        for t in (alg.obs, alg.actions, alg.log_prob, alg.values, alg.rewards):
            t.copy_(torch.randn(t.shape, generator=g, device=DEVICE))
        alg.dones.copy_(torch.rand(alg.dones.shape, generator=g, device=DEVICE) < 0.02)
    return alg


def sync() -> None:
    if DEVICE == "cuda":
        torch.cuda.synchronize()


def timed(alg: TorchPPO, updates: int) -> float:
    def one():
        alg.step = alg.cfg.rollout
        with torch.no_grad():
            alg.compute_returns({"policy": alg.obs[-1]})
        alg.update()
    for _ in range(2):  # compiles, captures
        one()
    sync()
    t0 = time.perf_counter()
    for _ in range(updates):
        alg.update()
    sync()
    return (time.perf_counter() - t0) / updates


def kernels(alg: TorchPPO) -> list:
    from torch.profiler import ProfilerActivity, profile
    with profile(activities=[ProfilerActivity.CUDA if DEVICE == "cuda" else ProfilerActivity.CPU]) as prof:
        alg.update()
        sync()
    rows = [(e.key, e.device_time_total / 1e3, e.count) for e in prof.key_averages()]
    return sorted(rows, key=lambda r: -r[1])[:8]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--task", default="CartPole", choices=sorted(SIZES))
    ap.add_argument("--envs", type=int, default=8192)
    ap.add_argument("--updates", type=int, default=3)
    ap.add_argument("--blocks", default="16,32,64")
    ap.add_argument("--warps", default="4,8")
    ap.add_argument("--precisions", default="ieee,tf32x3")
    ap.add_argument("--atomic", default="0,1")
    ap.add_argument("--json")
    ap.add_argument("--device", default="cuda", help="cpu: a dry run under TRITON_INTERPRET=1")
    a = ap.parse_args()
    global DEVICE
    DEVICE = a.device
    samples = a.envs * ppo_config(a.task).rollout
    rows = []
    alg = learner(a.task, a.envs, "off")
    s = timed(alg, a.updates)
    rows.append({"update": "torch", "ms": s * 1e3, "learn_sps": samples / s, "kernels": kernels(alg)})
    print(f"torch: {s * 1e3:.1f} ms an update, {samples / s:,.0f} samples/s", flush=True)
    del alg
    for block, warps, prec, atomic in itertools.product(
            [int(x) for x in a.blocks.split(",")], [int(x) for x in a.warps.split(",")],
            a.precisions.split(","), [bool(int(x)) for x in a.atomic.split(",")]):
        FusedUpdate.BLOCK, FusedUpdate.WARPS, FusedUpdate.PRECISION, FusedUpdate.ATOMIC = block, warps, prec, atomic
        name = f"fused block {block} warps {warps} {prec} {'atomic' if atomic else 'slots'}"
        try:
            alg = learner(a.task, a.envs, "on")
            s = timed(alg, a.updates)
            k = kernels(alg)
        except Exception as e:  # noqa: BLE001 (a setting the compiler refuses: say so and go on)
            print(f"{name}: failed: {type(e).__name__}: {str(e)[:300]}", flush=True)
            continue
        rows.append({"update": name, "ms": s * 1e3, "learn_sps": samples / s, "kernels": k})
        print(f"{name}: {s * 1e3:.1f} ms an update, {samples / s:,.0f} samples/s; "
              + "; ".join(f"{n[:24]} {ms:.1f} ms x{c}" for n, ms, c in k[:3]), flush=True)
        del alg
    if a.json:
        with open(a.json, "w") as f:
            json.dump({"task": a.task, "envs": a.envs, "samples_per_update": samples,
                       "device": torch.cuda.get_device_name() if DEVICE == "cuda" else "cpu", "torch": torch.__version__,
                       "rows": rows}, f, indent=1)


if __name__ == "__main__":
    main()
