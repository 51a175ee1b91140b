"""Training and data generation over two processes (torchrun: gloo on lavapipe, NCCL where
there are two GPUs) against one process with the same envs and seed."""
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

import cressim
from cressim.learn.distributed import Shard

# two processes need two GPUs where the engine runs on a GPU (each takes cuda:LOCAL_RANK)
GPUS = torch.cuda.device_count()
pytestmark = pytest.mark.skipif(GPUS == 1, reason="two processes need two GPUs (or none: lavapipe)")


def run_cli(*args, cwd):
    """`cressim ARGS` as a user runs it (--nproc runs torchrun); fails the test with its output."""
    env = {k: v for k, v in os.environ.items() if k not in ("RANK", "WORLD_SIZE", "LOCAL_RANK", "MASTER_ADDR", "MASTER_PORT")}
    # this package, wherever it was imported from (an editable install, or PYTHONPATH relative to the tree)
    env["PYTHONPATH"] = os.pathsep.join([str(Path(cressim.__file__).parents[1]), env.get("PYTHONPATH", "")])
    r = subprocess.run([sys.executable, "-m", "cressim", *args, "--device", "cuda" if GPUS else "cpu"], cwd=cwd, env=env, capture_output=True, text=True)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    return r.stdout


def test_two_processes_train_as_one(tmp_path):
    """Same seed, 32 envs as one process or as two of 16: every update's episodes and losses and
    the final weights agree (the shards draw the batch's numbers; DDP averages equal halves),
    with observation normalisation reduced over both processes."""
    common = ["train", "CartPole", "--envs", "32", "--iterations", "4", "--rollout", "16", "--minibatch", "512",
              "--backend", "torch", "--obs-normalization", "--seed", "5"]
    run_cli(*common, "--out", "one", cwd=tmp_path)
    out = run_cli(*common, "--out", "two", "--nproc", "2", cwd=tmp_path)
    assert "16 envs on each of 2 processes" in out
    one, two = (json.loads((tmp_path / d / "metrics.json").read_text()) for d in ("one", "two"))
    assert two["processes"] == 2 and two["num_envs"] == 32
    for a, b in zip(one["history"], two["history"], strict=True):
        assert (a["episodes"], a["mean_length"], a["mean_return"]) == (b["episodes"], b["mean_length"], b["mean_return"])
        for key in ("value", "surrogate", "entropy"):
            assert b[key] == pytest.approx(a[key], rel=1e-3, abs=1e-6), key
    w1, w2 = (torch.load(tmp_path / d / "model_4.pt", weights_only=False) for d in ("one", "two"))
    for part in ("actor_state_dict", "critic_state_dict"):
        for name, value in w1[part].items():
            assert torch.allclose(value, w2[part][name], rtol=1e-4, atol=1e-6), (part, name)
    assert w2["actor_state_dict"]["normalizer.samples"] == 32 * 16 * 4  # every process's observations


def test_engine_rollouts_on_two_processes_train_as_one(tmp_path):
    """The actor inside each process's engine frame (--engine-rollout): the shards draw the whole
    batch's exploration noise by env index, so two processes of 16 envs train as one of 32."""
    common = ["train", "CartPole", "--envs", "32", "--iterations", "2", "--rollout", "16", "--minibatch", "512",
              "--backend", "torch", "--engine-rollout", "--seed", "5"]
    run_cli(*common, "--out", "one", cwd=tmp_path)
    out = run_cli(*common, "--out", "two", "--nproc", "2", cwd=tmp_path)
    assert "policy in the engine" in out and "16 envs on each of 2 processes" in out
    one, two = (json.loads((tmp_path / d / "metrics.json").read_text()) for d in ("one", "two"))
    assert two["engine_rollout"] and two["processes"] == 2
    for a, b in zip(one["history"], two["history"], strict=True):
        assert (a["episodes"], a["mean_length"], a["mean_return"]) == (b["episodes"], b["mean_length"], b["mean_return"])
        for key in ("value", "surrogate", "entropy"):
            assert b[key] == pytest.approx(a[key], rel=1e-3, abs=1e-6), key
    w1, w2 = (torch.load(tmp_path / d / "model_2.pt", weights_only=False) for d in ("one", "two"))
    for name, value in w1["actor_state_dict"].items():
        assert torch.allclose(value, w2["actor_state_dict"][name], rtol=1e-4, atol=1e-6), name


def test_generated_shards_join_into_the_one_process_batch(tmp_path):
    """`cressim generate --nproc 2`: a bag a process and an index; read back with rosbags, the two
    shards side by side are the one-process recording, number for number."""
    pytest.importorskip("rosbags")
    from cressim.datasets.rollouts import read

    common = ["generate", "CartPole", "--envs", "6", "--steps", "12", "--seed", "2"]
    run_cli(*common, "--out", "one", cwd=tmp_path)
    run_cli(*common, "--out", "two", "--nproc", "2", cwd=tmp_path)
    index = json.loads((tmp_path / "two" / "index.json").read_text())
    assert [(s["path"], s["first_env"], s["envs"]) for s in index["shards"]] == [("shard_000", 0, 3), ("shard_001", 3, 3)]
    assert all(s["messages"]["/rollout/observation"] == 12 for s in index["shards"])
    one, two = read(tmp_path / "one"), read(tmp_path / "two")
    assert one["observation"].shape == (12, 6, 4) and one["action"].shape == (12, 6, 1)
    for name in one:
        assert np.array_equal(one[name], two[name]), name
    assert one["terminated"].any()  # random actions drop poles: resets happen inside the recording
    assert np.abs(one["action"]).max() <= 1 and len(np.unique(one["action"])) == one["action"].size


def test_an_uneven_split_is_refused():
    with pytest.raises(ValueError, match="10 envs do not split evenly over 4 processes"):
        Shard(rank=1, world=4).envs(10)
    assert Shard(rank=2, world=4).envs(12) == (3, 6)
