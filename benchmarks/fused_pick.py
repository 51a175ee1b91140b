"""PPO end to end with the fastest fused-update setting that bench_fused_update.py measured
(GPU batch helper): python3 benchmarks/fused_pick.py SETTINGS.json TASK ENVS OUT_DIR"""
import json
import sys

from cressim.learn.bench import run
from cressim.learn.fused_update import FusedUpdate

rows = [r for r in json.load(open(sys.argv[1]))["rows"] if r["update"].startswith("fused")]
best = min(rows, key=lambda r: r["ms"])["update"].split()
FusedUpdate.BLOCK, FusedUpdate.WARPS, FusedUpdate.PRECISION = int(best[2]), int(best[4]), best[5]
FusedUpdate.ATOMIC = best[6] == "atomic"
print("fused update:", " ".join(best), flush=True)
run(sys.argv[2], [int(n) for n in sys.argv[3].split(",")], mode="ppo", out_dir=sys.argv[4], device="cuda")
