"""skrl's own PPO and SequentialTrainer train through SkrlEnv on CartPole (lavapipe, CPU)."""
import pytest
import torch
from torch import nn

import cressim.envs

skrl = pytest.importorskip("skrl")
from skrl.agents.torch.ppo import PPO, PPO_CFG  # noqa: E402
from skrl.memories.torch import RandomMemory  # noqa: E402
from skrl.models.torch import DeterministicMixin, GaussianMixin, Model  # noqa: E402
from skrl.trainers.torch import SequentialTrainer  # noqa: E402

from cressim.learn.skrl_env import SkrlEnv  # noqa: E402


class Policy(GaussianMixin, Model):
    def __init__(self, observation_space, action_space, device):
        Model.__init__(self, observation_space=observation_space, action_space=action_space, device=device)
        GaussianMixin.__init__(self, clip_actions=True)
        self.net = nn.Sequential(nn.Linear(self.num_observations, 32), nn.Tanh(), nn.Linear(32, self.num_actions))
        self.log_std = nn.Parameter(torch.full((self.num_actions,), -0.5))

    def compute(self, inputs, role=""):
        return self.net(inputs["observations"]), {"log_std": self.log_std}


class Value(DeterministicMixin, Model):
    def __init__(self, observation_space, action_space, device):
        Model.__init__(self, observation_space=observation_space, action_space=action_space, device=device)
        DeterministicMixin.__init__(self)
        self.net = nn.Sequential(nn.Linear(self.num_observations, 32), nn.Tanh(), nn.Linear(32, 1))

    def compute(self, inputs, role=""):
        return self.net(inputs["observations"]), {}


def test_skrl_ppo_trains_through_the_env(tmp_path):
    torch.manual_seed(0)
    task = cressim.envs.make("CartPole", num_envs=8, seed=0)
    env = SkrlEnv(task)
    assert env.observation_space.shape == (4,) and env.action_space.shape == (1,) and env.num_envs == 8
    rollouts = 32
    memory = RandomMemory(memory_size=rollouts, num_envs=env.num_envs, device=env.device)
    models = {"policy": Policy(env.observation_space, env.action_space, env.device),
              "value": Value(env.observation_space, env.action_space, env.device)}
    cfg = PPO_CFG(rollouts=rollouts, learning_epochs=4, mini_batches=2, learning_rate=3e-4,
                  experiment={"directory": str(tmp_path), "write_interval": 0, "checkpoint_interval": 0})
    agent = PPO(models=models, memory=memory, observation_space=env.observation_space,
                action_space=env.action_space, device=env.device, cfg=cfg)
    before = [p.detach().clone() for p in models["policy"].parameters()]
    trainer = SequentialTrainer(env=env, agents=agent,
                                cfg={"timesteps": 4 * rollouts, "headless": True, "disable_progressbar": True,
                                     "close_environment_at_exit": False})
    trainer.train()
    assert any(not torch.equal(a, b) for a, b in zip(before, models["policy"].parameters()))  # 4 updates ran
    # the last rollout in skrl's memory: copies of the observations (each row a different step's), and
    # the poles that fell there (unbalanced, they fall within about 60 steps), tilted well past their start
    stored = memory.get_tensor_by_name("observations")
    assert stored.shape == (rollouts, 8, 4) and not torch.equal(stored[0], stored[1])
    ended = memory.get_tensor_by_name("terminated")[..., 0]
    assert ended.any()
    fallen = stored[ended]  # the observation the policy acted on in the step the pole fell
    assert torch.all((fallen[:, 0].abs() > 2.0) | (fallen[:, 2].abs() > 0.08))  # starts are within 0.05
    assert task.engine.validation_messages == []
