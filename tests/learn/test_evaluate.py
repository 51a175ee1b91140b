"""`cressim eval` (cressim.learn.evaluate): a trained policy's mean actions run whole episodes in
every env; returns, lengths and endings add up with what the env reports, and `cressim train`'s
small policy.pt (the actor alone) is what it reads."""
import json

import pytest
import torch

from cressim.cli import main
from cressim.learn import evaluate, train


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    out = tmp_path_factory.mktemp("cartpole")
    train("CartPole", num_envs=16, iterations=2, out_dir=out, rollout=16, minibatch=64, progress=False,
          backend="torch")
    return out


def test_policy_pt_holds_the_actor_alone(trained):
    small, full = torch.load(trained / "policy.pt", weights_only=False), torch.load(trained / "model_2.pt", weights_only=False)
    assert "critic_state_dict" not in small and "optimizer_state_dict" not in small
    for k, v in full["actor_state_dict"].items():
        assert torch.equal(small["actor_state_dict"][k], v)


def test_every_env_runs_its_episodes(trained):
    result = evaluate(trained / "policy.pt", num_envs=4, episodes=3)
    assert result["episodes"] == 12 and result["task"] == "CartPole"
    # CartPole pays 1 a step: each episode's return is its length; an early end is the pole's fall
    assert result["returns"] == result["lengths"] and all(1 <= n <= 500 for n in result["lengths"])
    assert result["terminated_each"] == [n < 500 for n in result["lengths"]]
    assert result["mean_return"] == pytest.approx(sum(result["lengths"]) / 12)
    assert result["terminated"] == pytest.approx(sum(result["terminated_each"]) / 12)


def test_the_command_line_writes_the_result(trained, tmp_path, capsys):
    path = tmp_path / "eval.json"
    assert main(["eval", str(trained / "policy.pt"), "--envs", "2", "--json", str(path)]) == 0
    assert json.loads(path.read_text())["episodes"] == 2 and "CartPole: 2 episodes" in capsys.readouterr().out
    with pytest.raises(ValueError, match="num_envs and episodes must be positive"):
        evaluate(trained / "policy.pt", num_envs=2, episodes=0)
