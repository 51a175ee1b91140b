"""CartPole throughput, TASKS.md's protocol (the same as `cressim bench CartPole ...`).

    PYTHONPATH=python python3 benchmarks/bench_cartpole.py --envs 256,1024,4096 --mode both
"""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "python"))

from cressim.cli import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main(["bench", "CartPole", *sys.argv[1:]]))
