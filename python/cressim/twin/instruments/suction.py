"""The suction tool (psm_suction, our own design): while its valve (`suction/servo_jp`, 0 shut ..
1 open) is open it removes the world's fluid within `arm.suction.radius` of its tube's end and
draws the fluid within `arm.suction.reach` in at the valve's share of `arm.suction.flow_rate`
(cressim.passes.Suction). Needs a world with fluid."""
from __future__ import annotations

import numpy as np
import torch

from cressim.passes.suction import Suction as SuctionPass

from ..command_checks import joint_values
from ..messages import Event
from .instrument import Instrument

SUCTION_TIP = (0.0, 0.0, 0.0091)  # m, in the suction tube link: the tube's open end


class Suction(Instrument):
    name = "suction"
    commands = {"suction/servo_jp": "servo_jp"}

    def __init__(self, arms, tube: str):
        scene, N = arms.scene, arms.num_envs
        bodies, point = arms.bodies.link_point(tube, SUCTION_TIP)
        self.suction = SuctionPass(arms.bodies.engine, bodies, point, scene.suction_radius,
                                   flow_rate=scene.suction_flow_rate, reach=scene.suction_reach)
        self.valve = torch.zeros(N, 1, dtype=torch.float64)
        self.removed = torch.zeros(N, 1, dtype=torch.float64)
        self.on = np.zeros(N, dtype=bool)
        self.share = np.zeros(N)  # the valve as last given to the pass

    @classmethod
    def build(cls, arms):
        tube = arms.link_named("suction_tube_link")
        if arms.simulated and tube and arms.bodies.has_fluid:
            return cls(arms, tube)
        return None

    @classmethod
    def absent(cls, arms, env, kind, value):
        why = (f"the {arms.robot} instrument has no suction tube" if not arms.link_named("suction_tube_link")
               else "the world has no fluid")
        return [Event(env, "error", f"{kind} refused: {why}")]

    def servo_jp(self, arms, env: int, cmd) -> list[Event]:
        kind = "suction/servo_jp"
        problem = arms.states[env].motion_refusal(kind)
        if problem is None:
            value, problem = joint_values(cmd, what=kind, names=("suction",), lower=np.zeros(1), upper=np.ones(1))
        if problem:
            return [Event(env, "error", problem)]
        self.valve[env, 0] = float(value[0])
        return []

    def before_step(self, arms):
        valve = self.valve[:, 0].numpy()
        on = valve > 0
        if (on != self.on).any() or (valve != self.share).any():
            self.suction.set(on)
            self.suction.set_flow(valve * arms.scene.suction_flow_rate)
            self.on, self.share = on, valve.copy()
        self.suction.execute()

    def after_step(self, arms):
        if self.on.any():
            self.removed = torch.as_tensor(self.suction.removed(), dtype=torch.float64)[:, None]

    def restart(self, arms):
        self.valve.zero_()

    def fields(self, arms):
        return {"suction_valve": self.valve, "suction_removed": self.removed}


__all__ = ["SUCTION_TIP", "Suction"]
