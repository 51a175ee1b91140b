"""The benchmark runs every mode on small counts and writes its JSON (saying what each number
measured) and plot."""
import json

from cressim.learn.bench import MEASURED, run


def test_bench_smoke(tmp_path):
    quick = {"warmup_steps": 2, "steps": 4, "warmup_updates": 1, "updates": 1, "rollout": 4}
    result = run("CartPole", [4], mode="all", out_dir=tmp_path, protocol=quick)
    saved = json.loads(next(tmp_path.glob("cartpole_all_*.json")).read_text())
    assert saved["env_counts"] == [4] and saved["device_name"] == result["device_name"]
    assert set(saved["measured"]) == set(MEASURED)
    for r in saved["results"]:
        assert all(r[k] > 0 for k in MEASURED), r
        assert r["ppo_policy"] == "engine" and r["policy_steps_per_submit"] == 4
    assert saved["reference"]["paper RTX 4090 step"]["4096"] == 1_249_689
    assert next(tmp_path.glob("cartpole_*.png")).stat().st_size > 1000


def test_ppo_with_the_policy_in_torch(tmp_path):
    quick = {"warmup_updates": 1, "updates": 1, "rollout": 4}
    run("CartPole", [4], mode="ppo", out_dir=tmp_path, protocol=quick, policy="torch")
    row = json.loads(next(tmp_path.glob("cartpole_ppo_*.json")).read_text())["results"][0]
    assert row["ppo_policy"] == "torch" and row["ppo_sps"] > 0 and "step_sps" not in row
