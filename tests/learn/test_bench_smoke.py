"""The benchmark runs both modes on small counts and writes its JSON and plot."""
import json

from cressim.learn.bench import run


def test_bench_smoke(tmp_path):
    quick = {"warmup_steps": 2, "steps": 4, "warmup_updates": 1, "updates": 1, "rollout": 4}
    result = run("CartPole", [4, 8], mode="both", out_dir=tmp_path, protocol=quick)
    saved = json.loads(next(tmp_path.glob("cartpole_*.json")).read_text())
    assert saved["env_counts"] == [4, 8] and saved["device_name"] == result["device_name"]
    assert all(r["step_sps"] > 0 and r["ppo_sps"] > 0 for r in saved["results"])
    assert saved["reference"]["paper RTX 4090 step"]["4096"] == 1_249_689
    assert next(tmp_path.glob("cartpole_*.png")).stat().st_size > 1000
