"""What the twin's arm models take and give, without ROS: commands in, events and snapshots out.

Every arm model (TwinArms for PSMs, EcmArm, MtmArm) and the ROS node speak these; they depend on
nothing else in the twin, so any module can import them without a cycle.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple, Sequence


class ConfigError(RuntimeError):
    """A bad start-up configuration (scene or parameter); nothing was built."""


class Event(NamedTuple):
    env: int
    topic: str
    value: object


class StateReport(NamedTuple):
    state: str
    is_homed: bool
    is_busy: bool


@dataclass
class JointCommand:
    """A joint command (what sensor_msgs/JointState carries): names may be empty (dVRK order)."""
    position: Sequence[float] = ()
    name: Sequence[str] = ()


class Snapshot:
    """One tick's published state: `snap.measured[env]` etc. ((N, width) host arrays by name)."""

    def __init__(self, sim_ns: int, fields: dict):
        self.sim_ns = sim_ns
        self.fields = fields

    def __getattr__(self, name):
        try:
            return self.__dict__["fields"][name]
        except KeyError:
            raise AttributeError(name) from None

    def __contains__(self, name):
        return name in self.fields


__all__ = ["ConfigError", "Event", "JointCommand", "Snapshot", "StateReport"]
