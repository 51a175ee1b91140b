"""On CUDA the built-in PPO replays its policy step and minibatch update as CUDA graphs: the
replayed update must equal the eager one, step for step, and the policy step must keep
writing what the current weights give (GPU machine only)."""

import pytest
import torch

from cressim.learn.config import PPOConfig
from cressim.learn.torch_ppo import TorchPPO

pytestmark = pytest.mark.skipif(not torch.cuda.is_available(), reason="no CUDA device")

CASES = {  # (config, observation shape, observation dtype); MLPs in torch (test_fused_update.py: in Triton)
    "mlp": (PPOConfig(rollout=16, minibatch=32, hidden=(32, 32), fused_update="off"), (6,), torch.float32),
    "cnn": (PPOConfig(rollout=16, minibatch=32, hidden=(64,), network="cnn"), (32, 32, 3), torch.uint8),
    # the normalisers' statistics change in place after each update: the replayed graphs must see them
    "mlp_normalized": (PPOConfig(rollout=16, minibatch=32, hidden=(32, 32), obs_normalization=True,
                                 fused_update="off"), (6,), torch.float32),
}


@pytest.fixture(autouse=True)
def exact_kernels():
    """fp32 without TF32 and deterministic cuDNN: eager and replayed runs differ only in
    summation order (Adam turns larger differences in near-zero gradients into whole steps)."""
    saved = (torch.backends.cuda.matmul.allow_tf32, torch.backends.cudnn.allow_tf32,
             torch.backends.cudnn.deterministic, torch.backends.cudnn.benchmark)
    torch.backends.cuda.matmul.allow_tf32 = torch.backends.cudnn.allow_tf32 = False
    torch.backends.cudnn.deterministic, torch.backends.cudnn.benchmark = True, False
    yield
    (torch.backends.cuda.matmul.allow_tf32, torch.backends.cudnn.allow_tf32,
     torch.backends.cudnn.deterministic, torch.backends.cudnn.benchmark) = saved


def _learner(case: str, num_envs: int = 8) -> TorchPPO:
    cfg, shape, dtype = CASES[case]
    torch.manual_seed(0)
    return TorchPPO(int(torch.tensor(shape).prod()), 2, num_envs, cfg, "cuda", shape, dtype)


def _fill(alg: TorchPPO, seed: int) -> None:
    g = torch.Generator(device="cuda").manual_seed(seed)
    with torch.no_grad():
        for t in (alg.obs, alg.actions, alg.log_prob, alg.values, alg.rewards):
            if t.dtype == torch.uint8:
                t.copy_(torch.randint(0, 256, t.shape, generator=g, device="cuda", dtype=torch.uint8))
            else:
                t.copy_(torch.randn(t.shape, generator=g, device="cuda") * 0.5)
        alg.dones.copy_(torch.rand(alg.dones.shape, generator=g, device="cuda") < 0.05)
        alg.step = alg.cfg.rollout
        alg.compute_returns({"policy": alg.obs[-1]})


@pytest.mark.parametrize("case", sorted(CASES))
def test_replayed_update_equals_eager(case):
    graph, eager = _learner(case), _learner(case)  # same seed: the same weights
    eager._learn_step.enabled = False
    for update in range(3):
        losses = []
        for alg in (graph, eager):
            _fill(alg, seed=update)
            torch.manual_seed(100 + update)  # the same minibatch order
            losses.append(alg.update())
        assert losses[0] == pytest.approx(losses[1], rel=1e-3, abs=1e-6), update
    assert graph._learn_step.graph is not None, "the update was never captured"
    for (name, p), q in zip([*graph.actor.named_parameters(), *graph.critic.named_parameters()],
                            [*eager.actor.parameters(), *eager.critic.parameters()]):
        assert torch.allclose(p, q, rtol=1e-3, atol=1e-5), name


@pytest.mark.parametrize("case", sorted(CASES))
def test_replayed_policy_step_follows_the_weights(case):
    alg = _learner(case)
    g = torch.Generator(device="cuda").manual_seed(7)

    def check(rounds: int) -> None:
        for _ in range(rounds):
            x = alg.obs[0].clone()
            if x.dtype == torch.uint8:
                x.copy_(torch.randint(0, 256, x.shape, generator=g, device="cuda", dtype=torch.uint8))
            else:
                x.normal_(generator=g)
            t = alg.step = 0
            with torch.inference_mode():
                a = alg.act({"policy": x}).clone()
                dist = alg._dist(x)
                assert torch.equal(alg.obs[t], x)
                assert torch.allclose(alg.values[t], alg.critic(x).squeeze(-1), rtol=1e-4, atol=1e-5)
                assert torch.allclose(alg.log_prob[t], dist.log_prob(a).sum(-1), rtol=1e-4, atol=1e-4)
                assert a.std() > 0.1  # sampled, not the mean

    check(5)  # eager warm-up calls, then the capture and replays
    assert alg._policy_step.graph is not None
    _fill(alg, seed=1)
    alg.update()  # new weights, changed in place: the replayed graph must see them
    check(2)


def test_compiled_update_equals_plain():
    """PPOConfig.compile (the minibatch step through torch.compile), replayed
    as a graph, gives the plain learner's update."""
    from dataclasses import replace

    cfg, shape, dtype = CASES["mlp"]
    learners = []
    for c in (cfg, replace(cfg, compile=True)):
        torch.manual_seed(0)
        learners.append(TorchPPO(shape[0], 2, 8, c, "cuda", shape, dtype))
    for update in range(5):  # the graph is captured after 3 eager minibatch steps
        losses = []
        for alg in learners:
            _fill(alg, seed=update)
            torch.manual_seed(100 + update)
            losses.append(alg.update())
        assert losses[1] == pytest.approx(losses[0], rel=1e-3, abs=1e-6), update
    assert learners[1]._learn_step.graph is not None
    for p, q in zip(learners[0].learned, learners[1].learned):
        assert torch.allclose(p, q, rtol=1e-3, atol=1e-5)
