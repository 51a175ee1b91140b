"""The needle driver's jaws grasp tissue (cressim.passes.Grasp): once the measured jaw angle falls
below `arm.grasp.closed_below` they take the particles within `arm.grasp.reach` of their middle
and hold them to the wrist until the angle rises again."""
from __future__ import annotations

import numpy as np

from cressim.passes.grasp import Grasp
from cressim.robots import JAW_GRASP_POINT

from .instrument import Instrument, jaws_closed


class Jaws(Instrument):
    name = "jaws"

    def __init__(self, arms, wrist: str):
        bodies, point = arms.bodies.link_point(wrist, JAW_GRASP_POINT)
        self.grasp = Grasp(arms.bodies.engine, bodies, point, arms.scene.grasp_reach)
        self.closed = np.zeros(arms.num_envs, dtype=bool)

    @classmethod
    def build(cls, arms):
        wrist = arms.link_named("wrist_yaw_link")
        if arms.simulated and arms.psm.has_jaw and wrist:
            return cls(arms, wrist)
        return None

    def before_step(self, arms):
        closed = jaws_closed(arms)
        if (closed != self.closed).any():  # the GPU pass acts on a change
            self.grasp.set(closed)
            self.closed = closed
        self.grasp.execute()


__all__ = ["Jaws"]
