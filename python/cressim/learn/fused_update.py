"""PPO's whole update for TASKS.md's MLPs as three Triton kernels a minibatch, replayed as one CUDA graph.

With TASKS.md's minibatch of 2,048 samples, CartPole at 8,192 envs makes 2,048 optimizer steps an
update, each a few dozen tiny kernels in torch (forward, backward, clipping, Adam); those steps,
not the rollout, bounded PPO. Here a minibatch step is:
  1. `_minibatch_grads`: each program takes BLOCK samples of the minibatch, runs actor and critic
     forward, the loss's gradient (clipped surrogate, value MSE, entropy) and both networks'
     backward, and stores its share of every gradient in a slot of its own;
  2. `_reduce`: the slots summed in order (the same sums every run), and the actor's and the
     critic's squared gradient norms;
  3. `_adam`: each network's gradients clipped to max_grad_norm, Adam's step on the parameters
     where they live (the engine policy may hold the actor's).
The update's 4 x minibatches steps are captured once as one CUDA graph and replayed. The math is
TorchPPO's, term for term (torch's tie rules for max and clamp included); tests compare the two.

Applies to actor and critic of two tanh layers of one width H <= 128 (a power of two) on float32
observations of at most 64 values, in one process; TorchPPO falls back to torch elsewhere.
"""
from __future__ import annotations

import os

import torch
from torch import nn

try:
    import triton
    import triton.language as tl
except ImportError:  # the learner then runs in torch
    triton = None

MAX_WIDTH, MAX_OBS, MAX_ACTIONS = 128, 64, 16


def interpreted() -> bool:
    return os.environ.get("TRITON_INTERPRET") == "1"


def _layers(module: nn.Module):
    """(normalizer or None, [Linear x3]) of [Normalized] Sequential(Linear, Tanh, Linear, Tanh, Linear)."""
    normalizer = getattr(module, "normalizer", None)
    net = module.net if normalizer is not None else module
    mods = list(net) if isinstance(net, nn.Sequential) else []
    if (len(mods) != 5 or not all(isinstance(m, nn.Linear) for m in mods[0::2])
            or not all(isinstance(m, nn.Tanh) for m in mods[1::2])):
        return None
    return normalizer, mods[0::2]


def why_not(alg) -> str | None:
    """Why `alg` (a TorchPPO) can't use the fused update, or None when it can."""
    if triton is None:
        return "triton is not installed"
    if alg.device.type != "cuda" and not (alg.device.type == "cpu" and interpreted()):
        return f"it runs on CUDA (or on the CPU under TRITON_INTERPRET=1), not {alg.device}"
    if alg.world > 1:
        return "it runs in one process (gradients are not all-reduced)"
    if alg.cfg.network != "mlp":
        return f"network {alg.cfg.network!r} is not an MLP"
    actor, critic = _layers(alg.actor), _layers(alg.critic)
    if actor is None or critic is None:
        return "actor and critic must be two tanh layers and a linear output"
    width = actor[1][0].out_features
    if any(l.out_features != width for net in (actor, critic) for l in net[1][:2]) or width > MAX_WIDTH \
            or width & (width - 1) or width < 16:
        return f"hidden layers must share one width, a power of two in [16, {MAX_WIDTH}], got {alg.cfg.hidden}"
    if alg.obs.dtype != torch.float32 or alg.obs.shape[-1] > MAX_OBS:
        return f"observations must be float32 vectors of at most {MAX_OBS} values"
    if alg.actions.shape[-1] > MAX_ACTIONS:
        return f"at most {MAX_ACTIONS} actions"
    return None


if triton is not None:
    BETA1, BETA2, EPS = tl.constexpr(0.9), tl.constexpr(0.999), tl.constexpr(1e-8)  # torch Adam's defaults
    HALF_LOG_2PI = tl.constexpr(0.9189385332046727)

    @triton.jit
    def _tanh(x):
        e = tl.exp(-2.0 * tl.abs(x))
        t = (1.0 - e) / (1.0 + e)
        return tl.where(x < 0, -t, t)

    @triton.jit
    def _forward(x, w1, b1, w2, b2, w3, b3, NIN: tl.constexpr, IP: tl.constexpr, NOUT: tl.constexpr,
                 OP: tl.constexpr, H: tl.constexpr, PREC: tl.constexpr):
        """h1, h2 and the output (BLOCK x OP, zero past NOUT) of a two-tanh-layer MLP."""
        k_in, j, o = tl.arange(0, IP), tl.arange(0, H), tl.arange(0, OP)
        w1t = tl.load(w1 + j[None, :] * NIN + k_in[:, None], mask=k_in[:, None] < NIN, other=0.0)  # IP x H
        h1 = _tanh(tl.dot(x, w1t, input_precision=PREC) + tl.load(b1 + j)[None, :])
        w2t = tl.load(w2 + j[None, :] * H + j[:, None])  # H x H: w2t[k, j] = W2[j, k]
        h2 = _tanh(tl.dot(h1, w2t, input_precision=PREC) + tl.load(b2 + j)[None, :])
        w3t = tl.load(w3 + o[None, :] * H + j[:, None], mask=o[None, :] < NOUT, other=0.0)  # H x OP
        out = tl.dot(h2, w3t, input_precision=PREC) + tl.load(b3 + o, mask=o < NOUT, other=0.0)[None, :]
        return h1, h2, out

    @triton.jit
    def _put(ptr, value, mask, ATOMIC: tl.constexpr):
        """A program's share of a gradient: added into the one sum, or stored in its own slot."""
        if ATOMIC:
            tl.atomic_add(ptr, value, mask=mask, sem="relaxed")
        else:
            tl.store(ptr, value, mask=mask)

    @triton.jit
    def _backward(dout, x, h1, h2, w2, w3, g, NIN: tl.constexpr, IP: tl.constexpr, NOUT: tl.constexpr,
                  OP: tl.constexpr, H: tl.constexpr, PREC: tl.constexpr, ATOMIC: tl.constexpr):
        """This block's gradients of W1, b1, W2, b2, W3, b3 (in that order, from `g`) for the
        output gradient `dout` (zero in padded rows and columns)."""
        k_in, j, o = tl.arange(0, IP), tl.arange(0, H), tl.arange(0, OP)
        g_b1 = g + H * NIN
        g_w2 = g_b1 + H
        g_b2 = g_w2 + H * H
        g_w3 = g_b2 + H
        g_b3 = g_w3 + NOUT * H
        out_rows = o[:, None] < NOUT
        _put(g_w3 + o[:, None] * H + j[None, :], tl.dot(tl.trans(dout), h2, input_precision=PREC), out_rows, ATOMIC)
        _put(g_b3 + o, tl.sum(dout, 0), o < NOUT, ATOMIC)
        w3 = tl.load(w3 + o[:, None] * H + j[None, :], mask=out_rows, other=0.0)  # OP x H
        dz2 = tl.dot(dout, w3, input_precision=PREC) * (1.0 - h2 * h2)
        _put(g_w2 + j[:, None] * H + j[None, :], tl.dot(tl.trans(dz2), h1, input_precision=PREC), None, ATOMIC)
        _put(g_b2 + j, tl.sum(dz2, 0), None, ATOMIC)
        w2 = tl.load(w2 + j[:, None] * H + j[None, :])
        dz1 = tl.dot(dz2, w2, input_precision=PREC) * (1.0 - h1 * h1)
        _put(g + j[:, None] * NIN + k_in[None, :], tl.dot(tl.trans(dz1), x, input_precision=PREC),
             k_in[None, :] < NIN, ATOMIC)
        _put(g_b1 + j, tl.sum(dz1, 0), None, ATOMIC)

    @triton.jit
    def _minibatch_grads(order, start, size, inv_size, obs, act, old_logp, ret, adv, mean, var,
                         aw1, ab1, aw2, ab2, aw3, ab3, log_std, cw1, cb1, cw2, cb2, cw3, cb3,
                         grads, sums, adam, clip, value_coef, entropy_coef,
                         NOBS: tl.constexpr, NACT: tl.constexpr, IP: tl.constexpr, AP: tl.constexpr,
                         H: tl.constexpr, BLOCK: tl.constexpr, NORMALIZE: tl.constexpr, PREC: tl.constexpr,
                         ATOMIC: tl.constexpr):
        pid = tl.program_id(0)
        NA_W: tl.constexpr = H * NOBS + H + H * H + H + NACT * H + NACT  # the actor's weights; then log_std
        NPARAM: tl.constexpr = 2 * (H * NOBS + H + H * H + H) + NACT * H + 2 * NACT + H + 1
        if not ATOMIC:  # each program its own slot of partial sums (_reduce adds them up)
            grads += pid * NPARAM
        r = pid * BLOCK + tl.arange(0, BLOCK)
        live = r < size
        row = tl.load(order + start + r, mask=live, other=0)
        k_in, a_i = tl.arange(0, IP), tl.arange(0, AP)
        in_mask = live[:, None] & (k_in[None, :] < NOBS)
        x = tl.load(obs + row[:, None] * NOBS + k_in[None, :], mask=in_mask, other=0.0)
        if NORMALIZE:  # ObsNormalizer: fixed statistics during an update
            m = tl.load(mean + k_in, mask=k_in < NOBS, other=0.0)
            v = tl.load(var + k_in, mask=k_in < NOBS, other=1.0)
            x = tl.where(in_mask, tl.minimum(tl.maximum((x - m[None, :]) / tl.sqrt(v[None, :] + 1e-8), -10.0), 10.0),
                         0.0)
        # actor: the Gaussian's log-probability ratio and the clipped surrogate's gradient
        h1, h2, mu = _forward(x, aw1, ab1, aw2, ab2, aw3, ab3, NOBS, IP, NACT, AP, H, PREC)
        a_mask = live[:, None] & (a_i[None, :] < NACT)
        a = tl.load(act + row[:, None] * NACT + a_i[None, :], mask=a_mask, other=0.0)
        ls = tl.load(log_std + a_i, mask=a_i < NACT, other=0.0)
        inv_var = tl.exp(-2.0 * ls)[None, :]
        diff = tl.where(a_mask, a - mu, 0.0)
        logp = tl.sum(tl.where(a_mask, -diff * diff * 0.5 * inv_var - ls[None, :] - HALF_LOG_2PI, 0.0), 1)
        ratio = tl.exp(logp - tl.load(old_logp + row, mask=live, other=0.0))
        advantage = tl.load(adv + row, mask=live, other=0.0)
        clipped = tl.minimum(tl.maximum(ratio, 1.0 - clip), 1.0 + clip)
        s1, s2 = -advantage * ratio, -advantage * clipped
        # torch.max's gradient splits ties in half; clamp passes it where lo <= ratio <= hi
        w1 = tl.where(s1 > s2, 1.0, tl.where(s1 == s2, 0.5, 0.0))
        inside = tl.where((ratio >= 1.0 - clip) & (ratio <= 1.0 + clip), 1.0, 0.0)
        d_ratio = tl.where(live, -advantage * (w1 + (1.0 - w1) * inside) * inv_size, 0.0)
        d_logp = (d_ratio * ratio)[:, None]
        d_mu = d_logp * diff * inv_var  # d logp / d mu = (a - mu) / sigma^2
        # d logp / d log_std = (a - mu)^2 / sigma^2 - 1; the entropy's, the same for every sample,
        # is -entropy_coef, counted once (by program 0)
        d_ls = tl.sum(tl.where(a_mask, d_logp * (diff * diff * inv_var - 1.0), 0.0), 0)
        d_ls -= tl.where((a_i < NACT) & (pid == 0), entropy_coef, 0.0)
        _put(grads + NA_W + a_i, d_ls, a_i < NACT, ATOMIC)
        _backward(d_mu, x, h1, h2, aw2, aw3, grads, NOBS, IP, NACT, AP, H, PREC, ATOMIC)
        # critic: the value loss's gradient
        h1, h2, v = _forward(x, cw1, cb1, cw2, cb2, cw3, cb3, NOBS, IP, 1, 16, H, PREC)
        value = tl.sum(tl.where(tl.arange(0, 16)[None, :] == 0, v, 0.0), 1)
        err = tl.where(live, value - tl.load(ret + row, mask=live, other=0.0), 0.0)
        d_v = tl.where(tl.arange(0, 16)[None, :] == 0, (2.0 * value_coef * inv_size * err)[:, None], 0.0)
        _backward(d_v, x, h1, h2, cw2, cw3, grads + NA_W + NACT, NOBS, IP, 1, 16, H, PREC, ATOMIC)
        surrogate = tl.where(live, tl.maximum(s1, s2), 0.0)
        tl.atomic_add(sums, tl.sum(err * err, 0) * inv_size, sem="relaxed")
        tl.atomic_add(sums + 1, tl.sum(surrogate, 0) * inv_size, sem="relaxed")
        if pid == 0:  # the entropy, sum over actions of 1/2 + log(2 pi)/2 + log_std, is the same for every sample
            tl.atomic_add(sums + 2, tl.sum(tl.where(a_i < NACT, 0.5 + HALF_LOG_2PI + ls, 0.0), 0), sem="relaxed")
            tl.store(adam + 1, 0.0)  # the squared norms _reduce adds up
            tl.store(adam + 2, 0.0)
            tl.store(adam, tl.load(adam) + 1.0)  # Adam's step count

    @triton.jit
    def _reduce(partials, parts, grads, adam, n_actor, n_all, CHUNK: tl.constexpr):
        """The gradients, summed over the programs' `parts` slots of partials (1: they are summed
        already), and the actor's and the critic's squared norms."""
        i = tl.program_id(0) * CHUNK + tl.arange(0, CHUNK)
        live = i < n_all
        g = tl.zeros((CHUNK,), tl.float32)
        for p in range(parts):
            g += tl.load(partials + p * n_all + i, mask=live, other=0.0)
        tl.store(grads + i, g, mask=live)
        tl.atomic_add(adam + 1, tl.sum(tl.where(i < n_actor, g * g, 0.0), 0), sem="relaxed")
        tl.atomic_add(adam + 2, tl.sum(tl.where(i >= n_actor, g * g, 0.0), 0), sem="relaxed")

    @triton.jit
    def _adam(table, grads, exp_avg, exp_avg_sq, adam, n_actor, lr, max_norm, ZERO: tl.constexpr,
              CHUNK: tl.constexpr):
        """Program (tensor, chunk): table rows are (parameter address, flat offset, size)."""
        t, c = tl.program_id(0), tl.program_id(1)
        offset, size = tl.load(table + 3 * t + 1), tl.load(table + 3 * t + 2)
        if c * CHUNK < size:
            param = tl.load(table + 3 * t).to(tl.pointer_type(tl.float32))
            i = c * CHUNK + tl.arange(0, CHUNK)
            live = i < size
            f = offset + i
            # clip_grad_norm_: max_norm / (norm + 1e-6), at most 1, each network on its own
            norm = tl.sqrt(tl.where(offset < n_actor, tl.load(adam + 1), tl.load(adam + 2)))
            g = tl.load(grads + f, mask=live, other=0.0) * tl.minimum(max_norm / (norm + 1e-6), 1.0)
            m = BETA1 * tl.load(exp_avg + f, mask=live, other=0.0) + (1.0 - BETA1) * g
            v = BETA2 * tl.load(exp_avg_sq + f, mask=live, other=0.0) + (1.0 - BETA2) * g * g
            step = tl.load(adam)
            bc1 = 1.0 - tl.exp(step * 0.10536051565782628 * -1.0)   # 1 - 0.9^step
            bc2 = 1.0 - tl.exp(step * 0.0010005003335835335 * -1.0)  # 1 - 0.999^step
            p = tl.load(param + i, mask=live, other=0.0) - lr / bc1 * m / (tl.sqrt(v) / tl.sqrt(bc2) + EPS)
            tl.store(param + i, p, mask=live)
            tl.store(exp_avg + f, m, mask=live)
            tl.store(exp_avg_sq + f, v, mask=live)
            if ZERO:  # for the next step's atomic sums
                tl.store(grads + f, 0.0, mask=live)


class FusedUpdate:
    """TorchPPO.update's epochs in Triton (module docstring). Holds Adam's moments and step count
    itself; `to_optimizer` / `from_optimizer` move them into and out of torch's Adam for save and load."""

    CHUNK = 1024
    # how the kernels run (benchmarks/bench_fused_update.py compares them): samples a program
    # (tl.dot's tiles are at least 16 wide), its warps, tl.dot's precision ("ieee": float32
    # FMAs; "tf32x3": tensor cores, three TF32 products for float32 accuracy), and whether the
    # programs add their gradients atomically or store them apart for _reduce to sum in order
    BLOCK, WARPS, PRECISION, ATOMIC = 32, 8, "tf32x3", False

    def __init__(self, alg):
        self.alg = alg
        # the critic's normaliser holds the same statistics as the actor's (both are updated alike)
        (self.normalizer, actor), (_, critic) = _layers(alg.actor), _layers(alg.critic)
        self.actor_params = [p for l in actor for p in (l.weight, l.bias)] + [alg.log_std]
        self.critic_params = [p for l in critic for p in (l.weight, l.bias)]
        self.params = self.actor_params + self.critic_params
        self.width = actor[0].out_features
        self.n_actor = sum(p.numel() for p in self.actor_params)
        self.n_all = self.n_actor + sum(p.numel() for p in self.critic_params)
        z = lambda n: torch.zeros(n, device=alg.device)  # noqa: E731
        self.grads, self.exp_avg, self.exp_avg_sq = z(self.n_all), z(self.n_all), z(self.n_all)
        self.adam = z(3)  # step count, actor's and critic's squared gradient norms
        self.order = torch.zeros(alg.obs.shape[0] * alg.obs.shape[1], device=alg.device, dtype=torch.int32)
        self.blocks = triton.cdiv(alg._minibatch.numel(), self.BLOCK)
        self.partials = self.grads if self.ATOMIC else z(self.blocks * self.n_all)
        self.graph, self.bound = None, None
        self.from_optimizer()

    def _bound(self) -> tuple:
        """What the captured kernels read and write by address: when any moves, the graph is recaptured."""
        a = self.alg
        return tuple(t.data_ptr() for t in (*self.params, a.obs, a.actions, a.log_prob, a.returns, a.advantages,
                                           a._loss_sums))

    def _steps(self) -> None:
        a, c = self.alg, self.alg.cfg
        n, size = a.num_mini_batches, a._minibatch.numel()
        obs_n, act_n = a.obs.shape[-1], a.actions.shape[-1]
        norm = self.normalizer
        mean, var = (norm.mean, norm.var) if norm is not None else (self.adam, self.adam)  # unread without one
        table = self.table
        prec = "ieee" if interpreted() else self.PRECISION
        for _ in range(c.epochs):
            for i in range(n):
                _minibatch_grads[(self.blocks,)](
                    self.order, i * size, size, 1.0 / size, a.obs, a.actions, a.log_prob, a.returns, a.advantages,
                    mean, var, *self.params, self.partials, a._loss_sums, self.adam,
                    c.clip, c.value_coef, c.entropy_coef, NOBS=obs_n, NACT=act_n,
                    IP=max(16, triton.next_power_of_2(obs_n)), AP=max(16, triton.next_power_of_2(act_n)),
                    H=self.width, BLOCK=self.BLOCK, NORMALIZE=norm is not None, PREC=prec, ATOMIC=self.ATOMIC,
                    num_warps=self.WARPS)
                _reduce[(triton.cdiv(self.n_all, self.CHUNK),)](
                    self.partials, 1 if self.ATOMIC else self.blocks, self.grads, self.adam, self.n_actor,
                    self.n_all, CHUNK=self.CHUNK)
                _adam[(len(self.params), triton.cdiv(max(p.numel() for p in self.params), self.CHUNK))](
                    table, self.grads, self.exp_avg, self.exp_avg_sq, self.adam, self.n_actor, c.lr,
                    c.max_grad_norm, ZERO=self.ATOMIC, CHUNK=self.CHUNK)

    def _offsets(self) -> list:
        out, o = [], 0
        for p in self.params:
            out.append(o)
            o += p.numel()
        return out

    def run(self, order: torch.Tensor) -> None:
        """All epochs of one update on the samples in `order` (one shuffle, reused by every epoch)."""
        self.order[:order.numel()].copy_(order)
        if self.alg.device.type != "cuda":
            self.table = self._table()
            self._steps()
        elif self.graph is not None and self.bound == self._bound():
            self.graph.replay()
        else:
            # the first update runs eagerly (and compiles the kernels); its launches are then
            # captured, not run, and every later update replays them
            self.table, self.bound = self._table(), self._bound()
            self._steps()
            self.graph = torch.cuda.CUDAGraph()
            with torch.cuda.graph(self.graph):
                self._steps()

    def _check_layout(self) -> None:
        """The kernels index the rollout as flat rows: its buffers (the learner's own, or the
        engine rollout's views) must be dense."""
        a = self.alg
        for name in ("obs", "actions", "log_prob", "returns", "advantages"):
            t = getattr(a, name)
            if not t.is_contiguous() or t.shape[:2] != a.obs.shape[:2]:
                raise ValueError(f"fused update: the learner's {name} must be a contiguous (rollout, envs, ...) "
                                 f"tensor, got shape {tuple(t.shape)} strides {t.stride()}")

    def _table(self) -> torch.Tensor:
        self._check_layout()
        return torch.tensor([[p.data_ptr(), o, p.numel()] for p, o in zip(self.params, self._offsets())],
                            dtype=torch.int64, device=self.alg.device)

    def to_optimizer(self, optimizer: torch.optim.Optimizer) -> None:
        """Writes Adam's moments and step count into `optimizer`'s state (for state_dict)."""
        with torch.no_grad():
            for p, o in zip(self.params, self._offsets()):
                optimizer.state[p] = {"step": self.adam[0].clone(),
                                      "exp_avg": self.exp_avg[o:o + p.numel()].view_as(p).clone(),
                                      "exp_avg_sq": self.exp_avg_sq[o:o + p.numel()].view_as(p).clone()}

    def from_optimizer(self) -> None:
        """Takes Adam's moments and step count from the learner's torch optimizer (after a load)."""
        state = self.alg.optimizer.state
        with torch.no_grad():
            for p, o in zip(self.params, self._offsets()):
                s = state.get(p)
                if s:
                    self.exp_avg[o:o + p.numel()].copy_(s["exp_avg"].reshape(-1))
                    self.exp_avg_sq[o:o + p.numel()].copy_(s["exp_avg_sq"].reshape(-1))
                    self.adam[0] = float(s["step"])
