"""TissueRetract: the batched PSM grasps the tissue flap's edge and lifts it; per-env resets put
the arm, the grasp and the tissue back; the CRTK observation tracks what a client can know; PPO
runs on it."""
import math

import numpy as np
import pytest
import torch

import cressim.envs
from cressim.envs.tissue_retract import ACTION_SCALE
from cressim.learn import train

from .on_host import on_host

RCM = (0.0, 0.0, 0.3)  # scenes/psm_twin.yaml's base, which psm_retraction.yaml keeps
START_Q = (0.0, 0.0, 0.1, 0.0, 0.0, 0.0)  # psm_retraction.yaml's home_jp
FLAP_TOP = 0.15 + 0.0015 + 0.006  # table top, particle radius, flap thickness (tissue_retraction.yaml)
FREE_EDGE = -0.02  # y of the flap's free edge
JOINTS, TARGET, TIP, ATTACHED, LIFT = slice(0, 6), slice(12, 15), slice(15, 18), 27, 28
# the grasp point sits this far beyond the insertion value along the shaft (wrist straight)
BEYOND = 0.3 - 0.1 - 0.2005


def reach(point: torch.Tensor) -> torch.Tensor:
    """Joint values that put the grasp point at `point` (N, 3) with the wrist straight: the shaft
    through the remote centre of motion."""
    v = point - torch.tensor(RCM, dtype=point.dtype, device=point.device)
    d = v.norm(dim=-1)
    u = v / d[:, None]
    zero = torch.zeros_like(d)
    return torch.stack([torch.atan2(u[:, 0], -u[:, 2]), torch.asin(-u[:, 1]), d - BEYOND, zero, zero, zero], -1)


def toward(obs: torch.Tensor, point: torch.Tensor, grasp: float) -> torch.Tensor:
    scale = torch.tensor(ACTION_SCALE, device=obs.device)
    a = ((reach(point) - obs[:, JOINTS]) / scale).clamp(-1, 1)
    return torch.cat([a, torch.full_like(a[:, :1], grasp)], 1)


def test_reset_observation_and_a_grasp_on_nothing():
    env = cressim.envs.make("TissueRetract", num_envs=2, validation=True)
    obs, info = on_host(env.reset(seed=1))
    assert obs.shape == (2, 29) and env.single_action_space.shape == (7,)
    assert torch.allclose(obs[:, JOINTS], torch.tensor(START_Q)) and torch.all(obs[:, 6:12] == 0)
    assert torch.allclose(obs[:, TARGET][:, 1:], torch.tensor([FREE_EDGE, FLAP_TOP]), atol=1e-4)  # on the free edge
    assert torch.allclose(obs[:, TIP], torch.tensor([0.0, 0.0, 0.2005]), atol=1e-5)
    assert torch.allclose(obs[:, 24:27], obs[:, TARGET] - obs[:, TIP])
    close = torch.zeros(2, 7)
    close[0, 6], close[1, 2] = 1.0, 1.0  # env 0 closes in the air; env 1 pushes its insertion
    for _ in range(5):
        obs, reward, terminated, truncated, _ = on_host(env.step(close))
    assert torch.all(obs[:, ATTACHED] == 0)  # nothing within reach
    assert env.grasp_commands[0, 0] == 1 and env.grasp_commands[0, 2] == 2  # closed on nothing
    assert math.isclose(float(obs[1, 2]), START_Q[2] + 5 * ACTION_SCALE[2], rel_tol=1e-5)
    assert math.isclose(float(obs[1, 8]), ACTION_SCALE[2] * 60, rel_tol=1e-4)  # m/s
    assert float(obs[1, TIP][2]) < 0.2005 - 0.0049
    distance = (obs[:, TARGET] - obs[:, TIP]).norm(dim=1)
    assert torch.allclose(reward, -distance / 0.1, atol=1e-5) and not (terminated | truncated).any()
    assert env.engine.validation_messages == []


@pytest.mark.parametrize("absorbing", [False, True])
def test_scripted_grasp_and_lift_succeeds_alone_and_resets_that_env(absorbing):
    env = cressim.envs.make("TissueRetract", num_envs=2, absorbing_success=absorbing, validation=True)
    obs, _ = on_host(env.reset())
    rest = env.engine.buffer("particles.positions").read()[:, :3].copy()
    above = torch.tensor([0.0, 0.0, 0.002])  # the grasp point just over the target particle
    closed_at, lift_to, rewards = None, None, []
    for step in range(1, 120):
        o = obs.clone()
        if closed_at is None and (o[0, TIP] - o[0, TARGET] - above).norm() < 0.001:
            closed_at, lift_to = step, (o[0, TARGET] + torch.tensor([0.0, 0.0, 0.03])).expand(2, 3)
        if closed_at is None:
            a = toward(o, o[:, TARGET] + above, -1.0)  # approach with the jaws open
        else:
            a = toward(o, lift_to, 1.0)  # close and lift
        a[1] = 0  # env 1 idles
        obs, reward, terminated, truncated, info = on_host(env.step(a))
        assert not terminated[1] and not truncated.any() and torch.all(info["health"] == 0)
        if step == closed_at:
            assert obs[0, ATTACHED] == 1 and obs[0, LIFT] < 0.2
        if closed_at is not None and not terminated[0]:
            rewards.append(float(reward[0]))
        if terminated[0]:
            break
    assert terminated[0], "the scripted retraction did not succeed"
    assert 20 <= closed_at <= 60 and len(rewards) >= 10
    if absorbing:  # the success step's reward (4 to 4.5: attached, lifted, the tip near the target) for each step left
        assert 4.0 * (181 - step) < float(reward[0]) <= 4.5 * (181 - step)
    assert rewards[-1] > rewards[0] + 3.0  # the lift term pays (up to 4)
    assert float(info["finished_length"][0]) == step and int(info["episode_length"][1]) == step
    # env 0 starts afresh: arm at its start, grasp open, tissue at rest; env 1 is untouched
    assert torch.allclose(obs[0, JOINTS], torch.tensor(START_Q)) and obs[0, ATTACHED] == 0
    assert torch.allclose(obs[0, TIP], torch.tensor([0.0, 0.0, 0.2005]), atol=1e-5)
    assert env.grasp_commands[0, 0] == 0 and env.grasp_commands[0, 3] == 0
    x = env.engine.buffer("particles.positions").read()[:, :3].reshape(2, -1, 3)
    assert np.abs(x - rest.reshape(2, -1, 3)).max() < 1e-3
    assert env.engine.validation_messages == []


def test_crtk_observation_is_what_a_client_knows():
    """observation="crtk": the target is the particle's rest position, 27 the commanded grasp, 28
    the tip's rise since the grasp closed; the state observation's env beside it sees the particle
    itself rise with the tip."""
    envs = {kind: cressim.envs.make("TissueRetract", num_envs=1, observation=kind, validation=True)
            for kind in ("crtk", "state")}
    obs = {kind: on_host(env.reset(seed=3))[0] for kind, env in envs.items()}
    rest = obs["crtk"][0, TARGET].clone()
    above = torch.tensor([0.0, 0.0, 0.002])
    closed_tip, lifted = None, {}
    for step in range(150):
        o = obs["crtk"]
        if closed_tip is None and (o[0, TIP] - o[0, TARGET] - above).norm() < 0.001:
            closed_tip = o[0, TIP].clone()
        a = toward(o, o[:, TARGET] + above, -1.0) if closed_tip is None else \
            toward(o, (closed_tip + torch.tensor([0.0, 0.0, 0.012]))[None], 1.0)
        for kind, env in envs.items():
            obs[kind] = on_host(env.step(a))[0]
        if closed_tip is not None and (obs["crtk"][0, TIP] - closed_tip)[2] > 0.0119:
            lifted = {kind: o.clone() for kind, o in obs.items()}
            break
    assert lifted, "the scripted grasp did not lift the tip by 12 mm"
    crtk, state = lifted["crtk"][0], lifted["state"][0]
    assert torch.allclose(crtk[TARGET], rest)  # the rest position, not the moving particle
    assert crtk[ATTACHED] == 1 and state[ATTACHED] == 1
    assert math.isclose(float(crtk[LIFT]), float((crtk[TIP] - closed_tip)[2]) / 0.02, abs_tol=1e-4)
    assert 0.55 < float(crtk[LIFT]) < 0.65
    assert state[TARGET][2] > rest[2] + 0.005  # the held particle rose with the jaws
    assert torch.allclose(crtk[:12], state[:12]) and torch.allclose(crtk[TIP], state[TIP], atol=1e-6)
    for env in envs.values():
        assert env.engine.validation_messages == []


def test_arguments_are_checked():
    for bad in ({"target_lift": float("nan")}, {"grasp_reach": 0}, {"observation": "pixels"}, {"absorbing_success": 1}):
        with pytest.raises(ValueError, match=next(iter(bad))):
            cressim.envs.make("TissueRetract", num_envs=1, **bad)
    with pytest.raises(ValueError, match="num_envs"):
        cressim.envs.make("TissueRetract", num_envs=0)
    with pytest.raises(ValueError, match="needle driver"):
        cressim.envs.make("TissueRetract", num_envs=1, scene="psm_suction.yaml")


def test_ppo_smoke(tmp_path):
    result = train("TissueRetract", num_envs=2, iterations=2, seed=0, out_dir=tmp_path, rollout=8, save_every=2,
                   progress=False)
    assert result["ppo"]["hidden"] == (256, 256) and result["ppo"]["minibatch"] == 1024
    for rec in result["history"]:
        assert all(math.isfinite(rec[k]) for k in ("value", "surrogate", "entropy")), rec
    assert (tmp_path / "model_2.pt").is_file()


def test_the_client_computes_the_crtk_observation_from_measured_cp():
    """cressim.envs.tissue_retract_client, fed the tool tip pose a twin publishes for the task's
    joint targets (measured_cp = the tip FK in the base frame), computes the batched task's CRTK
    observation, and steps the joint targets as the task does, over random actions with the grasp
    closing and opening."""
    from cressim.envs.tissue_retract_client import TissueRetractClient

    env = cressim.envs.make("TissueRetract", num_envs=1, observation="crtk", validation=True)
    obs, _ = on_host(env.reset(seed=5))
    client = TissueRetractClient(obs[0, TARGET].numpy())
    rng = np.random.default_rng(0)
    for step in range(40):
        q = env.joints[0, :6].detach().cpu().to(torch.float64)
        measured_cp = client.psm.forward_kinematics(q).numpy()
        mine = client.observation(measured_cp)
        np.testing.assert_allclose(mine, obs[0].numpy(), atol=1e-4, err_msg=f"step {step}")  # float32 FK
        a = rng.uniform(-1, 1, 7).astype(np.float32)
        a[6] = 1.0 if 10 <= step < 30 else -1.0  # closed in the middle, so the lift counts
        a[2] = -1.0 if 10 <= step < 30 else a[2]  # and the tip rises meanwhile
        targets, jaw = client.act(a)
        obs = on_host(env.step(torch.as_tensor(a)[None]))[0]
        assert jaw == (0.0 if 10 <= step < 30 else 0.6)
    assert env.engine.validation_messages == []
