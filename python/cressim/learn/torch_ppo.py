"""A compact PPO in plain torch, used when rsl-rl-lib is not installed (the GPU machine has
only numpy, torch, matplotlib, pytest). Same settings and the same method names as
rsl_rl.algorithms.PPO (act, process_env_step, compute_returns, update, save, load), so one
training loop drives either; the update follows rsl-rl's: whole-rollout advantage
normalisation, time-out bootstrapping, one shuffle reused by all epochs, gradients clipped
separately for actor and critic. On CUDA the policy step and the minibatch update are replayed
as CUDA graphs (cuda_graph.py): the networks are small enough that launching kernels one by one
would cost more than running them. TASKS.md's MLPs update through fused Triton kernels instead, the
whole update one graph (fused_update.py, PPOConfig.fused_update)."""
from __future__ import annotations

import math

import torch
from torch import nn
from torch.distributions import Normal

from .config import PPOConfig
from .cuda_graph import Captured
from .distributed import active, all_sum, average_gradients, broadcast
from .fused_update import FusedUpdate, why_not


def tanh_layers(inputs: int, hidden: tuple) -> list:
    layers, width = [], inputs
    for h in hidden:
        layers += [nn.Linear(width, h), nn.Tanh()]
        width = h
    return layers


def mlp(inputs: int, hidden: tuple, outputs: int) -> nn.Sequential:
    return nn.Sequential(*tanh_layers(inputs, hidden), nn.Linear(hidden[-1] if hidden else inputs, outputs))


def conv_trunk(channels: int) -> nn.Sequential:
    """TASKS.md's convolutions: conv32 k5 s2, conv64 k3 s2, conv64 k3 s2, each with a ReLU, flattened."""
    return nn.Sequential(nn.Conv2d(channels, 32, 5, 2), nn.ReLU(), nn.Conv2d(32, 64, 3, 2), nn.ReLU(),
                         nn.Conv2d(64, 64, 3, 2), nn.ReLU(), nn.Flatten())


class ImageCNN(nn.Module):
    """TASKS.md's image network (conv32 k5 s2, conv64 k3 s2, conv64 k3 s2, ReLU, linear `hidden`)
    on flat observations of `shape`: (channels, H, W) stacks such as UltrasoundScan's, or
    (H, W, channels) camera images such as TargetCenter's; uint8 values are scaled to [0, 1]."""

    def __init__(self, shape: tuple, hidden: int, outputs: int):
        super().__init__()
        self.shape = tuple(shape)
        self.channels_last = shape[-1] <= 4 < shape[0]
        channels = shape[-1] if self.channels_last else shape[0]
        self.convs = conv_trunk(channels)
        with torch.no_grad():
            width = self.convs(self._images(torch.zeros(1, math.prod(shape)))).shape[1]
        self.head = nn.Sequential(nn.Linear(width, hidden), nn.ReLU(), nn.Linear(hidden, outputs))

    def _images(self, x: torch.Tensor) -> torch.Tensor:
        x = x.reshape(-1, *self.shape)
        if self.channels_last:
            x = x.permute(0, 3, 1, 2)
        return x.float() / 255.0 if x.dtype == torch.uint8 else x

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.head(self.convs(self._images(x)))


class HybridNet(nn.Module):
    """TASKS.md's hybrid network on flat observations: a vector, then an (H, W, C) image of shape
    `image` (floats in [0, 1], or uint8 scaled to them). The image goes through the CNN's
    convolutions and a linear layer of hidden[0] (ReLU), the vector through the tanh MLP of
    `hidden`; the two are concatenated (fused) into the linear output layer."""

    def __init__(self, num_obs: int, image: tuple, hidden: tuple, outputs: int):
        super().__init__()
        self.image, self.vector = tuple(image), num_obs - math.prod(image)
        if len(self.image) != 3 or self.vector < 1 or not hidden:
            raise ValueError(f"network 'hybrid' needs an (H, W, C) image smaller than the {num_obs} observation values "
                             f"and hidden layers, got image {image}, hidden {hidden}")
        self.convs = conv_trunk(self.image[2])
        with torch.no_grad():
            width = self.convs(torch.zeros(1, self.image[2], self.image[0], self.image[1])).shape[1]
        self.image_features = nn.Sequential(nn.Linear(width, hidden[0]), nn.ReLU())
        self.vector_features = nn.Sequential(*tanh_layers(self.vector, hidden))
        self.head = nn.Linear(hidden[0] + hidden[-1], outputs)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        images = x[:, self.vector:].reshape(-1, *self.image).permute(0, 3, 1, 2)
        images = images.float() / 255.0 if images.dtype == torch.uint8 else images
        features = [self.image_features(self.convs(images)), self.vector_features(x[:, :self.vector].float())]
        return self.head(torch.cat(features, -1))


class ObsNormalizer(nn.Module):
    """The first `count` observation values by their running mean and std (clipped to +-10 std);
    the rest (an image) as they come. `update` merges a batch's statistics (Chan et al.'s parallel
    variance), in place: a CUDA graph that reads the buffers sees the new values."""

    def __init__(self, num_obs: int, count: int):
        super().__init__()
        self.count = count
        self.register_buffer("mean", torch.zeros(count))
        self.register_buffer("var", torch.ones(count))
        self.register_buffer("samples", torch.zeros(()))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        numbers = ((x[:, :self.count].float() - self.mean) / (self.var + 1e-8).sqrt()).clamp(-10.0, 10.0)
        return torch.cat([numbers, x[:, self.count:].to(numbers.dtype)], 1) if x.shape[1] > self.count else numbers

    @torch.no_grad()
    def update(self, batch: torch.Tensor) -> None:
        """Merges `batch`, and under torch.distributed every process's batch (the same statistics
        on each process: mean, then spread about it, summed over the processes)."""
        x = batch[:, :self.count].float()
        sums = all_sum(torch.cat([x.sum(0), x.new_tensor([x.shape[0]])]))
        n, mean = sums[-1], sums[:-1] / sums[-1]
        var = all_sum((x - mean).square().sum(0)) / n
        total = self.samples + n
        delta = mean - self.mean
        self.var.copy_((self.var * self.samples + var * n + delta.square() * self.samples * n / total) / total)
        self.mean.add_(delta * n / total)
        self.samples.copy_(total)


class Normalized(nn.Module):
    def __init__(self, normalizer: ObsNormalizer, net: nn.Module):
        super().__init__()
        self.normalizer, self.net = normalizer, net

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.net(self.normalizer(x))


def network(cfg: PPOConfig, num_obs: int, obs_shape: tuple | None, outputs: int) -> nn.Module:
    net = _network(cfg, num_obs, obs_shape, outputs)
    if not cfg.obs_normalization:
        return net
    if cfg.network == "cnn":
        raise ValueError("PPOConfig.obs_normalization: a 'cnn' policy sees only an image; nothing to normalise")
    return Normalized(ObsNormalizer(num_obs, net.vector if cfg.network == "hybrid" else num_obs), net)


def _network(cfg: PPOConfig, num_obs: int, obs_shape: tuple | None, outputs: int) -> nn.Module:
    if cfg.network == "mlp":
        return mlp(num_obs, cfg.hidden, outputs)
    if cfg.network == "cnn":
        if obs_shape is None or len(obs_shape) != 3:
            raise ValueError(f"network 'cnn' needs image observations (C, H, W) or (H, W, C), got shape {obs_shape}")
        return ImageCNN(obs_shape, cfg.hidden[0], outputs)
    if cfg.network == "hybrid":
        return HybridNet(num_obs, cfg.image, cfg.hidden, outputs)
    raise ValueError(f"PPOConfig.network {cfg.network!r}: use 'mlp', 'cnn' or 'hybrid'")


class TorchPPO:
    def __init__(self, num_obs: int, num_actions: int, num_envs: int, cfg: PPOConfig, device,
                 obs_shape: tuple | None = None, obs_dtype: torch.dtype = torch.float32):
        self.cfg, self.device = cfg, torch.device(device)
        self.actor = network(cfg, num_obs, obs_shape, num_actions).to(self.device)
        self.critic = network(cfg, num_obs, obs_shape, 1).to(self.device)
        self.log_std = nn.Parameter(torch.full((num_actions,), cfg.init_log_std, device=self.device))
        self.actor_params = [*self.actor.parameters(), self.log_std]
        # under torch.distributed this process's envs are rows [rank N, (rank + 1) N) of the whole
        # batch; every process starts from rank 0's weights and steps with the gradients averaged
        # over the processes (distributed.average_gradients), so the weights stay equal
        self.world = torch.distributed.get_world_size() if active() else 1
        self.rank = torch.distributed.get_rank() if active() else 0
        self.learned = [*self.actor_params, *self.critic.parameters()]
        broadcast([*self.learned, *self.actor.buffers(), *self.critic.buffers()])
        # the shuffles draw from a generator of their own: the default one draws the action noise,
        # whose stream must not depend on how large a process's share of the batch is
        self._shuffle = torch.Generator(self.device)
        self._shuffle.manual_seed(torch.initial_seed() + 1)
        # capturable: the step count stays on the device, so the update can be a CUDA graph
        self.optimizer = torch.optim.Adam(self.learned, lr=cfg.lr, capturable=self.device.type == "cuda")
        self.learning_rate = cfg.lr
        self.num_mini_batches = cfg.num_mini_batches(num_envs)  # per process, as DDP's batch size is
        T, N = cfg.rollout, num_envs
        z = lambda *shape, dtype=torch.float32: torch.zeros(T, N, *shape, device=self.device, dtype=dtype)  # noqa: E731
        # observations are stored as they come: a float rollout of uint8 images would be 4x larger
        self.obs, self.actions = z(num_obs, dtype=obs_dtype), z(num_actions)
        self.log_prob, self.values, self.rewards, self.returns = z(), z(), z(), z()
        self.advantages = z()
        self.dones = z(dtype=torch.bool)
        self.step = 0
        # the graphs' fixed inputs: this step's observations, one minibatch's sample indices
        self._act_obs = torch.zeros(N, num_obs, device=self.device, dtype=obs_dtype)
        self._minibatch = torch.zeros(T * N // self.num_mini_batches, device=self.device, dtype=torch.long)
        self._loss_sums = torch.zeros(3, device=self.device)  # value, surrogate, entropy; read once per update
        # compiled: the loss's forward and backward, and the clipping with Adam's step, as a few fused kernels
        self._losses = torch.compile(self._minibatch_losses) if cfg.compile else self._minibatch_losses
        self._apply = torch.compile(self._apply_gradients) if cfg.compile else self._apply_gradients
        self._policy_step = Captured(self._sample_policy, self.device)
        self._learn_step = Captured(self._learn_minibatch, self.device)
        self._fused = self._fused_update()

    def _fused_update(self) -> FusedUpdate | None:
        mode = self.cfg.fused_update
        if mode not in ("auto", "on", "off"):
            raise ValueError(f"PPOConfig.fused_update must be 'auto', 'on' or 'off', got {mode!r}")
        reason = None if mode == "off" else why_not(self)
        if mode == "on" and reason:
            raise ValueError(f"PPOConfig.fused_update='on' does not apply here: {reason}")
        return FusedUpdate(self) if mode != "off" and reason is None else None

    @property
    def fused(self) -> bool:
        """Whether update() runs as fused Triton kernels (fused_update.py) rather than torch."""
        return self._fused is not None

    def _dist(self, x: torch.Tensor) -> Normal:
        # no argument checks: they read values back to the host, a sync per call (and no graph)
        return Normal(self.actor(x), self.log_std.exp(), validate_args=False)

    def _sample_policy(self):
        x = self._act_obs
        dist = self._dist(x)
        # loc + scale * N(0, 1), the noise drawn for the whole batch and this process's rows taken:
        # the actions one process with every env would take, whatever the split
        n = x.shape[0]
        noise = torch.randn(self.world * n, *dist.loc.shape[1:], device=x.device)[self.rank * n:(self.rank + 1) * n]
        a = dist.loc + dist.scale * noise
        return a, dist.log_prob(a).sum(-1), self.critic(x).squeeze(-1)

    def act(self, obs) -> torch.Tensor:
        x, t = obs["policy"], self.step
        self._act_obs.copy_(x)
        a, log_prob, value = self._policy_step()
        self.obs[t].copy_(x)
        self.actions[t].copy_(a)
        self.log_prob[t].copy_(log_prob)
        self.values[t].copy_(value)
        return self.actions[t]

    def process_env_step(self, obs, rewards, dones, extras) -> None:
        # a truncated episode is not a failure: add the discounted value of where it stopped
        t = self.step
        self.rewards[t] = rewards + self.cfg.gamma * self.values[t] * extras["time_outs"]
        self.dones[t] = dones
        self.step += 1

    def compute_returns(self, obs) -> None:
        c = self.cfg
        next_values, adv = self.critic(obs["policy"]).squeeze(-1), 0.0
        for t in reversed(range(self.step)):
            live = (~self.dones[t]).float()
            delta = self.rewards[t] + live * c.gamma * next_values - self.values[t]
            adv = delta + live * c.gamma * c.lam * adv
            self.returns[t] = adv + self.values[t]
            next_values = self.values[t]
        # normalised over the whole batch, every process's rollout
        a = self.returns - self.values
        sums = all_sum(torch.stack([a.sum(), a.new_tensor(a.numel())]))
        mean = sums[0] / sums[1]
        std = (all_sum((a - mean).square().sum()) / (sums[1] - 1)).sqrt()
        self.advantages.copy_((a - mean) / (std + 1e-8))

    def _minibatch_losses(self) -> tuple:
        """(loss, [value, surrogate, entropy] detached) on the samples indexed by self._minibatch."""
        c, b = self.cfg, self._minibatch
        flat = lambda x: x.flatten(0, 1)[b]  # noqa: E731
        obs, actions, old_logp = flat(self.obs), flat(self.actions), flat(self.log_prob)
        returns, advantages = flat(self.returns), flat(self.advantages)
        dist = self._dist(obs)
        ratio = torch.exp(dist.log_prob(actions).sum(-1) - old_logp)
        surrogate = torch.max(-advantages * ratio, -advantages * ratio.clamp(1 - c.clip, 1 + c.clip)).mean()
        value = (returns - self.critic(obs).squeeze(-1)).pow(2).mean()
        entropy = dist.entropy().sum(-1).mean()
        loss = surrogate + c.value_coef * value - c.entropy_coef * entropy
        return loss, torch.stack([value, surrogate, entropy]).detach()

    def _apply_gradients(self) -> None:
        """Clips actor and critic gradients apart, then Adam's step."""
        nn.utils.clip_grad_norm_(self.actor_params, self.cfg.max_grad_norm)
        nn.utils.clip_grad_norm_(self.critic.parameters(), self.cfg.max_grad_norm)
        self.optimizer.step()

    def _learn_minibatch(self) -> None:
        """One optimizer step on the samples indexed by self._minibatch."""
        loss, parts = self._losses()
        self.optimizer.zero_grad()
        loss.backward()
        average_gradients(self.learned)
        self._apply()
        self._loss_sums += parts

    def update(self) -> dict:
        c, n, size = self.cfg, self.num_mini_batches, self._minibatch.numel()
        order = torch.randperm(n * size, device=self.device, generator=self._shuffle)
        self._loss_sums.zero_()
        if self._fused:
            self._fused.run(order)
        else:
            for _ in range(c.epochs):
                for i in range(n):
                    self._minibatch.copy_(order[i * size:(i + 1) * size])
                    self._learn_step()
        if c.obs_normalization:  # after the update: the rollout and its update saw the same statistics
            seen = self.obs[:self.step].flatten(0, 1)
            self.actor.normalizer.update(seen)
            self.critic.normalizer.update(seen)
        self.step = 0
        value, surrogate, entropy = (all_sum(self._loss_sums) / (c.epochs * n * self.world)).tolist()
        return {"value": value, "surrogate": surrogate, "entropy": entropy}

    def train_mode(self) -> None:
        self.actor.train(), self.critic.train()

    def save(self) -> dict:
        if self._fused:  # its Adam state lives in its own buffers
            self._fused.to_optimizer(self.optimizer)
        return {"actor_state_dict": self.actor.state_dict(), "critic_state_dict": self.critic.state_dict(),
                "log_std": self.log_std.detach().clone(), "optimizer_state_dict": self.optimizer.state_dict()}

    def load(self, saved: dict) -> None:
        self.actor.load_state_dict(saved["actor_state_dict"])
        self.critic.load_state_dict(saved["critic_state_dict"])
        with torch.no_grad():
            self.log_std.copy_(saved["log_std"])
        self.optimizer.load_state_dict(saved["optimizer_state_dict"])
        if self._fused:
            self._fused.from_optimizer()
