"""Batched joint trajectories for move_jp / move_cp / home, with velocity and acceleration limits.

One trajectory slot per env. Starting one (a message for env i) writes that env's row only;
evaluating runs every env in a few tensor ops. Each trajectory is a straight line in joint
space, q(t) = start + (goal - start) s(t), with s a trapezoidal (or triangular) profile from 0
to 1. s's own velocity and acceleration limits are the tightest over joints,
V = min_j v_j / |dq_j| and A = min_j a_j / |dq_j|, so every joint keeps within its limits and
all joints arrive together (the path stays the straight line; the dVRK's own interpolator
synchronises its joints in the same way).
"""
from __future__ import annotations

import torch


class BatchedTrajectory:
    def __init__(self, num_envs: int, dof: int, *, device="cpu", dtype=torch.float64):
        kw = dict(device=device, dtype=dtype)
        self.start_q = torch.zeros(num_envs, dof, **kw)
        self.delta = torch.zeros(num_envs, dof, **kw)
        self.t0 = torch.zeros(num_envs, **kw)  # start time (s, the twin's simulated time)
        self.v = torch.ones(num_envs, **kw)  # profile's velocity limit (1/s)
        self.a = torch.ones(num_envs, **kw)  # profile's acceleration limit (1/s^2)
        self.duration = torch.zeros(num_envs, **kw)
        self.active = torch.zeros(num_envs, dtype=torch.bool, device=device)
        self._idle = None  # evaluate's answer while nothing moves

    def start(self, env: int, q_from, q_to, v_limit, a_limit, now: float) -> float:
        """Starts env's trajectory from q_from to q_to (dof,) at time `now`; returns its duration."""
        q_from = torch.as_tensor(q_from, dtype=self.start_q.dtype, device=self.start_q.device)
        q_to = torch.as_tensor(q_to, dtype=self.start_q.dtype, device=self.start_q.device)
        delta = q_to - q_from
        dist = delta.abs().clamp_min(1e-12)
        v = float((torch.as_tensor(v_limit, dtype=dist.dtype, device=dist.device) / dist).min())
        a = float((torch.as_tensor(a_limit, dtype=dist.dtype, device=dist.device) / dist).min())
        # triangular when the profile cannot reach V before half way (V^2 / A >= 1)
        duration = 2.0 * (1.0 / a) ** 0.5 if v * v / a >= 1.0 else 1.0 / v + v / a
        if float(delta.abs().max()) < 1e-12:
            duration = 0.0
        self.start_q[env], self.delta[env] = q_from, delta
        self.t0[env], self.v[env], self.a[env], self.duration[env] = now, v, a, duration
        self.active[env] = True
        return duration

    def stop(self, env: int):
        self.active[env] = False

    def evaluate(self, now: float):
        """(q, qdot, moving, finished) for all envs at time `now`.

        q and qdot are (N, dof), meaningful where moving (N,) bool: the trajectory was active at
        this call. finished (N,) marks the ones that reached their goal now (q is exactly the
        goal there); they are made inactive. With none active (the usual tick: servo commands, or
        at rest) the answer is short: nothing moving, q the last goals (the flags and qdot are
        shared tensors: read them, do not write).
        """
        if not bool(self.active.any()):
            if self._idle is None:
                n, dof = self.start_q.shape
                none = torch.zeros(n, dtype=torch.bool, device=self.active.device)
                self._idle = (self.start_q.new_zeros(n, dof), none, none.clone())
            qd, moving, finished = self._idle
            return self.start_q + self.delta, qd, moving, finished
        t = (now - self.t0).clamp_min(0.0)
        T, V, A = self.duration, self.v, self.a
        t_acc = torch.minimum(V / A, (1.0 / A).sqrt())  # accel phase (the triangle's half)
        v_peak = A * t_acc
        t_dec = T - t_acc
        s_acc = 0.5 * A * t * t
        s_cruise = 0.5 * A * t_acc * t_acc + v_peak * (t - t_acc)
        td = (T - t).clamp_min(0.0)
        s_dec = 1.0 - 0.5 * A * td * td
        s = torch.where(t < t_acc, s_acc, torch.where(t < t_dec, s_cruise, s_dec))
        sd = torch.where(t < t_acc, A * t, torch.where(t < t_dec, v_peak, A * td))
        finished = self.active & (t >= T)
        s = torch.where(finished, torch.ones_like(s), s.clamp(0.0, 1.0))
        sd = torch.where(finished, torch.zeros_like(sd), sd)
        q = self.start_q + self.delta * s[:, None]
        qd = self.delta * sd[:, None]
        moving = self.active.clone()
        self.active &= ~finished
        return q, qd, moving, finished


__all__ = ["BatchedTrajectory"]
