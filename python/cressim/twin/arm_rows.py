"""Several arms of one engine env as the rows of one TwinArms (a patient cart's PSMs).

    rows = ArmRows([psm1_bodies, psm2_bodies, psm3_bodies])   # ArmBodies of one instrument, env 0 each
    arms = TwinArms(config, bodies=rows, initial_jp=..., home_jp=...)
    arms.tick()                                               # every PSM one period, batched

TwinArms keeps its state as (N, 6) rows and ticks them together; its `bodies` is what poses them
in the engine. A cart's PSMs are separate ArmBodies (each its own base, collision group and
segmentation ids) in the same engine env, so row k here is arm k's env 0: `write` hands each
arm its row, `reset` resets the one env they share, `base` is every arm's base (N, 4, 4).
Only kinematic arms over a world the cart steps itself (TwinArms then never steps the engine).
"""
from __future__ import annotations

import torch

from cressim.robots.arm_bodies import ArmBodies


class ArmRows:
    dynamic = False
    simulated = False  # the cart steps the world (cressim.twin.cart)
    has_fluid = has_heat = False
    needle_rows = None

    def __init__(self, arms: list[ArmBodies]):
        if len({(a.dof, tuple(a.link_names)) for a in arms}) > 1:
            raise ValueError("ArmRows: the arms must be one robot (one kinematics for every row)")
        self.arms = arms
        self.num_envs = len(arms)
        first = arms[0]
        self.engine, self.device, self.link_names = first.engine, first.device, first.link_names
        self.body_names = first.body_names
        self.base = torch.stack([a.base for a in arms])  # (N, 4, 4): each arm's base in the world

    def set_rate(self, dt: float, substeps: int, particle_substeps: int = 0):
        self.arms[0].set_rate(dt, substeps, particle_substeps)  # the engine's: one for all

    def write(self, q: torch.Tensor, jaw: torch.Tensor):
        """Poses every arm's links at its row of q (N, >= dof) and jaw (N, 1) (GPU FK passes)."""
        for k, arm in enumerate(self.arms):
            arm.write(q[k: k + 1], jaw[k: k + 1])

    def prepare_reset(self, rows: torch.Tensor, q: torch.Tensor, jaw: torch.Tensor):
        for i, k in enumerate(torch.as_tensor(rows).reshape(-1).tolist()):
            self.arms[k].prepare_reset(torch.tensor([0]), q[i: i + 1], jaw[i: i + 1])

    def reset(self, rows: list[int]):
        if len(rows):
            self.arms[0].reset([0])  # the env every row lives in


__all__ = ["ArmRows"]
