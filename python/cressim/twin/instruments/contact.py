"""The contact wrench on the tool (shaft, wrist and jaws): what contacts and held tissue exert on
it over the last tick, force (N) and torque (N m) about the tool tip, world axes. The snapshot
gives it in the base frame (`spatial_cf`) and the tip frame (`body_cf`)."""
from __future__ import annotations

import torch

from .instrument import Instrument

TOOL_LINKS = ("shaft_link", "wrist_pitch_link", "wrist_yaw_link", "jaw_1_link", "jaw_2_link")  # name endings


class ContactWrench(Instrument):
    name = "contact"

    def __init__(self, arms):
        self.links = [n for n in arms.bodies.link_names if n.endswith(TOOL_LINKS)]
        self.wrench = torch.zeros(arms.num_envs, 6, dtype=torch.float64)

    @classmethod
    def build(cls, arms):
        return cls(arms)  # always: the snapshot's wrench is zero where nothing is sensed

    def after_step(self, arms):
        if self.links:
            tip = (arms.bodies.base @ arms.kin.forward(arms.measured))[:, :3, 3]
            self.wrench = arms.bodies.contact_wrench(self.links, tip)


__all__ = ["ContactWrench", "TOOL_LINKS"]
