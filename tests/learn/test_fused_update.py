"""The fused PPO update (learn/fused_update.py: Triton kernels, the whole update one CUDA graph)
must move the weights, Adam's moments and the reported losses as TorchPPO's torch update does,
within float tolerance, from the same rollout and the same shuffle. On CUDA it runs as compiled kernels and
replayed graphs; on this CPU-only machine under Triton's interpreter (TRITON_INTERPRET=1, set
before triton is imported: a child process)."""
import os
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import pytest
import torch

from cressim.learn.config import PPOConfig
from cressim.learn.torch_ppo import TorchPPO

triton = pytest.importorskip("triton")

# (observations, actions, envs, config): a minibatch that is not a multiple of the kernel's block of
# 32 samples, padded observation and action widths, and the observation normaliser
CASES = {
    "mlp": (5, 2, 16, PPOConfig(hidden=(32, 32), minibatch=40, rollout=8)),
    "normalized": (7, 3, 16, PPOConfig(hidden=(16, 16), minibatch=64, rollout=8, obs_normalization=True)),
    "width128": (4, 1, 8, PPOConfig(hidden=(128, 128), minibatch=48, rollout=12, clip=0.05)),
}


def _learner(case: str, fused: str, device: str) -> TorchPPO:
    obs, actions, envs, cfg = CASES[case]
    torch.manual_seed(0)
    return TorchPPO(obs, actions, envs, replace(cfg, fused_update=fused), device)


def _fill(alg: TorchPPO, seed: int) -> None:
    g = torch.Generator().manual_seed(seed)
    with torch.no_grad():
        for t in (alg.obs, alg.actions, alg.log_prob, alg.values, alg.rewards):
            t.copy_(torch.randn(t.shape, generator=g) * 2.0)
        alg.log_prob.sub_(2.0)  # ratios on both sides of the clip range
        alg.dones.copy_(torch.rand(alg.dones.shape, generator=g) < 0.1)
        alg.step = alg.cfg.rollout
        alg.compute_returns({"policy": alg.obs[-1]})
        if alg.cfg.obs_normalization:
            for net in (alg.actor, alg.critic):
                net.normalizer.update(alg.obs.flatten(0, 1) * 3.0 + 1.0)


def compare(case: str, device: str, updates: int = 3) -> list:
    """Runs `updates` updates on the torch and the fused learner; returns the worst differences
    (weights, Adam's moments, losses) with the weights' largest magnitude."""
    plain, fused = _learner(case, "off", device), _learner(case, "on", device)
    assert fused.fused and not plain.fused
    out = []
    for u in range(updates):
        losses = []
        for alg in (plain, fused):
            _fill(alg, seed=u)
            losses.append(alg.update())
        state = [alg.save()["optimizer_state_dict"]["state"] for alg in (plain, fused)]
        moments = max((state[0][i][k] - state[1][i][k]).abs().max().item()
                      for i in state[0] for k in ("exp_avg", "exp_avg_sq"))
        steps = {float(state[1][i]["step"]) for i in state[1]} | {float(state[0][i]["step"]) for i in state[0]}
        weights = max((a - b).abs().max().item() for a, b in zip(plain.learned, fused.learned))
        loss = max(abs(losses[0][k] - losses[1][k]) / max(1.0, abs(losses[0][k])) for k in losses[0])
        out.append((weights, moments, loss, len(steps), max(p.abs().max().item() for p in plain.learned)))
    return out


def _check(rows: list) -> None:
    """Float tolerance: the kernels sum in another order, and on the GPU multiply through tensor
    cores (three TF32 products a float32 one); the weights move up to 3e-4 a step."""
    for weights, moments, loss, steps, size in rows:
        assert steps == 1  # both Adams counted the same optimizer steps
        assert weights < 1e-5 * max(size, 1.0), rows
        assert moments < 1e-5 and loss < 1e-4, rows


@pytest.mark.parametrize("case", sorted(CASES))
def test_the_fused_update_equals_torchs(case):
    if torch.cuda.is_available():
        _check(compare(case, "cuda"))
        return
    _check(_child(case))


def resume(device: str) -> float:
    """The largest weight difference between a fused learner that ran two updates and one loaded
    from its checkpoint after the first that then ran the second."""
    a = _learner("mlp", "on", device)
    _fill(a, 0)
    a.update()
    b = _learner("mlp", "on", device)
    b.load(a.save())
    b._shuffle.set_state(a._shuffle.get_state())  # a checkpoint holds no shuffle: draw the same one
    for alg in (a, b):
        _fill(alg, 1)
        alg.update()
    return max((x - y).abs().max().item() for x, y in zip(a.learned, b.learned))


def _child(what: str):
    env = {**os.environ, "TRITON_INTERPRET": "1"}
    run = subprocess.run([sys.executable, __file__, what], env=env, capture_output=True, text=True, timeout=1800)
    assert run.returncode == 0, run.stdout + run.stderr
    return eval(run.stdout.strip().splitlines()[-1])


def test_a_saved_fused_learner_resumes_where_it_stopped():
    """Adam's moments and step count live in the fused update's buffers: save() and load() carry them."""
    assert (resume("cuda") if torch.cuda.is_available() else _child("resume")) == 0.0


def test_fused_on_names_why_it_does_not_apply():
    cuda = torch.cuda.is_available()
    with pytest.raises(ValueError, match="width" if cuda else "runs on CUDA"):
        TorchPPO(4, 1, 8, PPOConfig(hidden=(256, 256), minibatch=32, rollout=8, fused_update="on"),
                 "cuda" if cuda else "cpu")
    with pytest.raises(ValueError, match="fused_update must be"):
        TorchPPO(4, 1, 8, PPOConfig(minibatch=32, rollout=8, fused_update="yes"), "cpu")


if __name__ == "__main__":  # the interpreter's child: python test_fused_update.py CASE
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "python"))
    print(resume("cpu") if sys.argv[1] == "resume" else compare(sys.argv[1], "cpu"))
