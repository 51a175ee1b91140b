"""A suture needle (`arm.needle`) held by the jaws: closed, they carry it (a kinematic body; the
jaws' body bears its weight and the tissue's pull on it); opened past `grasp.closed_below`, they
let it go (a dynamic body: it falls, held by the punctures it is threaded through); closed again
with its arc within `grasp.reach` of their middle, they pick it up where they hold it."""
from __future__ import annotations

import math

import numpy as np
import torch

from .instrument import Instrument, jaws_closed


class Needle(Instrument):
    name = "needle"

    def __init__(self, arms):
        bodies, N = arms.bodies, arms.num_envs
        authored = torch.zeros_like(arms.setpoint[:1])  # held as authored, at the initial joints
        authored[0, :len(bodies.authored_q)] = torch.as_tensor(bodies.authored_q)
        tip0 = bodies.base.to(torch.float64) @ arms.kin.forward(authored)[0]
        self.offset0 = torch.linalg.solve(tip0, torch.as_tensor(bodies.needle_pose0))
        self.arc_angle, self.arc_radius = arms.scene.needle["arc_angle"], arms.scene.needle["arc_radius"]
        A, R = self.arc_angle, self.arc_radius
        self.grip = self.offset0 @ torch.tensor([R * math.cos(A / 3), R * math.sin(A / 3), 0.0, 1.0],
                                                dtype=torch.float64)  # the jaws' middle
        self.offset = self.offset0.repeat(N, 1, 1)  # (N, 4, 4): each held needle's arc frame in the tip frame
        self.held = np.ones(N, dtype=bool)
        self.jaws_were_closed = np.ones(N, dtype=bool)

    @classmethod
    def build(cls, arms):
        return cls(arms) if arms.bodies.needle_rows is not None else None

    def before_step(self, arms):
        closed = jaws_closed(arms)
        bodies = arms.bodies
        tip = bodies.base.to(torch.float64) @ arms.kin.forward(arms.measured)  # (N, 4, 4) world
        was_held = self.held.copy()
        self.held &= closed
        take = np.flatnonzero(closed & ~self.jaws_were_closed & ~self.held)
        self.jaws_were_closed = closed
        if take.size:  # a host read of those needles only when jaws close on none
            self._pick_up(arms, take, tip)
        for now in (False, True):  # let go of: dynamic from this frame on; taken: kinematic, the jaws bear it
            changed = np.flatnonzero((was_held != self.held) & (self.held == now))
            if changed.size:
                bodies.hold_needle(torch.as_tensor(changed), now)
        held = np.flatnonzero(self.held)
        if held.size:
            held_t = torch.as_tensor(held)
            bodies.place_needle(held_t, tip[held_t] @ self.offset[held_t])

    def _pick_up(self, arms, take, tip):
        """Rows whose jaws just closed: those with the needle's arc within reach of the jaws' middle hold it."""
        needles = arms.bodies.needle_poses(torch.as_tensor(take))
        local = torch.linalg.solve(needles, tip[take] @ self.grip)[:, :3]  # the jaws' middle, arc frame
        A, R = self.arc_angle, self.arc_radius
        phi = torch.atan2(local[:, 1], local[:, 0])
        phi = torch.where(phi < -0.5 * (2 * math.pi - A), phi + 2 * math.pi, phi).clamp(0.0, A)
        on_arc = torch.stack([R * torch.cos(phi), R * torch.sin(phi), torch.zeros_like(phi)], 1)
        near = ((local - on_arc).norm(dim=1) <= arms.scene.grasp_reach).numpy()
        for k, env in enumerate(take):
            if near[k]:
                self.held[env] = True
                self.offset[env] = torch.linalg.solve(tip[env], needles[k])

    def reset(self, arms, envs):
        """The needle as authored, held in the jaws."""
        self.offset[envs] = self.offset0
        self.held[envs.numpy()] = True
        self.jaws_were_closed[envs.numpy()] = True
        arms.bodies.hold_needle(envs, True)

    def pose(self, arms, env: int) -> np.ndarray:
        """The needle's arc frame in the world (4x4)."""
        return arms.bodies.needle_poses(torch.tensor([env]))[0].numpy()

    def set_pose(self, arms, env: int, pose: np.ndarray) -> None:
        """Puts env's needle (arc frame, world 4x4) there now, at rest and out of the jaws (free: it
        falls from there; closing them over it picks it up again)."""
        self.held[env] = False
        with arms.engine_lock:
            arms.bodies.hold_needle(torch.tensor([env]), False)
            arms.bodies.set_needle_pose(torch.tensor([env]), torch.as_tensor(pose, dtype=torch.float64)[None])


__all__ = ["Needle"]
