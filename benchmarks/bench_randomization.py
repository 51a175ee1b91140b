"""CartPole stepping throughput with and without domain randomization (randomization_cartpole.yaml:
two masses drawn at every reset, the drive's damping every 50 steps), same protocol as
`cressim bench --mode step` (zero actions in place, final observations off).

    PYTHONPATH=python python3 benchmarks/bench_randomization.py --envs 1024,4096,8192

Prints one JSON line per env count: step_sps without and with randomization and their ratio.
"""
import argparse
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "python"))

from cressim import envs  # noqa: E402
from cressim.learn.bench import sync  # noqa: E402

TERMS = Path(__file__).with_name("randomization_cartpole.yaml")


def step_sps(num_envs: int, randomization, warmup: int = 64, steps: int = 256) -> float:
    env = envs.make("CartPole", num_envs=num_envs, seed=0, final_observation=False, randomization=randomization)
    env.reset()
    zeros = env.actions
    zeros.zero_()
    for _ in range(warmup):
        env.step(zeros)
        sync(env.device)
    t0 = time.perf_counter()
    for _ in range(steps):
        env.step(zeros)
        sync(env.device)
    rate = steps * num_envs / (time.perf_counter() - t0)
    env.close()
    return rate


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--envs", default="1024,4096,8192")
    p.add_argument("--steps", type=int, default=256)
    args = p.parse_args()
    for n in (int(v) for v in args.envs.split(",")):
        plain = step_sps(n, None, steps=args.steps)
        randomized = step_sps(n, TERMS, steps=args.steps)
        print(json.dumps({"envs": n, "step_sps": round(plain), "step_sps_randomized": round(randomized),
                          "ratio": round(randomized / plain, 3)}), flush=True)


if __name__ == "__main__":
    main()
