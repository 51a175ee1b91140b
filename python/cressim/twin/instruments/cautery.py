"""The needle driver's jaws energized by the coag pedal (the dVRK console's footpedals/coag):
pressed while the arm is enabled, they deliver `arm.cautery.power` into the tissue within
`arm.cautery.radius` of their middle (cressim.passes.Cautery; `arm.cautery.mode`: coag heats,
cut also parts coagulated tissue). Needs a world whose tissue takes heat."""
from __future__ import annotations

import numpy as np

from cressim.passes.cautery import Cautery as CauteryPass
from cressim.robots import JAW_GRASP_POINT

from ..messages import Event
from .instrument import Instrument


class Cautery(Instrument):
    name = "cautery"
    commands = {"footpedals/coag": "press"}

    def __init__(self, arms, wrist: str):
        scene = arms.scene
        bodies, point = arms.bodies.link_point(wrist, JAW_GRASP_POINT)
        self.cautery = CauteryPass(arms.bodies.engine, bodies, point, scene.cautery_radius, power=scene.cautery_power)
        self.cautery.set_mode([scene.cautery_mode == "cut"] * arms.num_envs)
        self.pedal = np.zeros(arms.num_envs, dtype=bool)
        self.on = np.zeros(arms.num_envs, dtype=bool)

    @classmethod
    def build(cls, arms):
        wrist = arms.link_named("wrist_yaw_link")
        if arms.simulated and arms.psm.has_jaw and wrist and arms.bodies.has_heat:
            return cls(arms, wrist)
        return None

    @classmethod
    def absent(cls, arms, env, kind, pressed):
        if not pressed:  # a release has nothing to refuse
            return []
        why = (f"the {arms.robot} instrument has no jaws to energize" if not arms.psm.has_jaw
               else "the world has no tissue that takes heat (a soft_body with thermal)")
        return [Event(env, "error", f"{kind} refused: {why}")]

    def press(self, arms, env: int, pressed: bool) -> list[Event]:
        self.pedal[env] = bool(pressed)
        return []

    def before_step(self, arms):
        on = self.pedal.copy()
        for env in np.flatnonzero(on):  # the pressed pedals only: no per-env work while none is
            on[env] = arms.states[env].state == "ENABLED"
        if (on != self.on).any():
            self.cautery.set(on)
            self.on = on
        self.cautery.execute()

    def restart(self, arms):
        self.pedal[:] = False


__all__ = ["Cautery"]
