"""The operating-state machine of one arm (CRTK: DISABLED, ENABLED, PAUSED, FAULT; is_homed, is_busy).

One instance per env. It only decides; the node carries out what a Transition asks (start
homing, stop motion, publish). State commands are rare events, so a Python object per env
costs nothing per tick; the joint states themselves are batched tensors in the node.

Rules (the dVRK's where it has one; docs/twin.md lists them):
- enable: any state -> ENABLED (also clears FAULT; from PAUSED it resumes).
- disable: -> DISABLED; motion stops (homing too), is_busy false; is_homed is kept.
- home: from ENABLED, or from DISABLED (the dVRK powers the arm up first, so do we): is_busy
  while homing, then is_homed. Refused when PAUSED or FAULT. Homing again re-publishes.
- unhome: is_homed false, motion stops. pause: ENABLED -> PAUSED, motion stops.
  resume: PAUSED -> ENABLED.
- Motion commands (servo_*, move_*, jaw) need ENABLED and homed, and no homing under way.
Every accepted command publishes a fresh operating_state (stamped after the command), even
when nothing changed: clients wait for a message newer than their command.
"""
from __future__ import annotations

from dataclasses import dataclass

DISABLED, ENABLED, PAUSED, FAULT = "DISABLED", "ENABLED", "PAUSED", "FAULT"
STATE_COMMANDS = ("enable", "disable", "home", "unhome", "pause", "resume")


@dataclass
class Transition:
    publish: bool = False  # publish operating_state
    desired: str | None = None  # publish desired_state
    start_homing: bool = False
    stop_motion: bool = False
    error: str | None = None  # the command was refused: why
    status: str | None = None  # a line for the status topic


class ArmState:
    def __init__(self):
        self.state = DISABLED
        self.is_homed = False
        self.homing = False
        self.busy = False  # a trajectory (move, jaw move, homing) is running; set by the node

    @property
    def is_busy(self) -> bool:
        return self.busy or self.homing

    def command(self, cmd: str) -> Transition:
        if cmd == "enable":
            was = self.state
            self.state = ENABLED
            return Transition(publish=True, desired=ENABLED, status=None if was == ENABLED else "enabled")
        if cmd == "disable":
            self.state, self.homing, self.busy = DISABLED, False, False
            return Transition(publish=True, desired=DISABLED, stop_motion=True, status="disabled")
        if cmd == "home":
            if self.state in (PAUSED, FAULT):
                return Transition(error=f"home refused: the arm is {self.state} (send "
                                        f"{'resume' if self.state == PAUSED else 'enable'} first)")
            self.state, self.homing = ENABLED, True
            return Transition(publish=True, desired="HOMED", start_homing=True, stop_motion=True, status="homing")
        if cmd == "unhome":
            self.is_homed, self.homing, self.busy = False, False, False
            return Transition(publish=True, stop_motion=True, status="unhomed")
        if cmd == "pause":
            if self.state != ENABLED:
                return Transition(error=f"pause refused: the arm is {self.state}, not ENABLED")
            self.state, self.homing, self.busy = PAUSED, False, False
            return Transition(publish=True, desired=PAUSED, stop_motion=True, status="paused")
        if cmd == "resume":
            if self.state not in (PAUSED, ENABLED):
                return Transition(error=f"resume refused: the arm is {self.state}, not PAUSED")
            self.state = ENABLED
            return Transition(publish=True, desired=ENABLED, status="resumed")
        return Transition(error=f"unknown state command {cmd!r}; expected one of {', '.join(STATE_COMMANDS)}")

    def homing_done(self):
        self.homing, self.is_homed = False, True

    def fault(self):
        """A numerical fault in the simulation (the node reports why): motion stops."""
        self.state, self.homing, self.busy = FAULT, False, False

    def motion_refusal(self, what: str) -> str | None:
        """None when a motion command may run now, else the reason it is refused."""
        if self.state != ENABLED:
            hint = {DISABLED: "send enable and home first", PAUSED: "send resume first",
                    FAULT: "send enable to clear the fault"}[self.state]
            return f"{what} refused: the arm is {self.state} ({hint})"
        if self.homing:
            return f"{what} refused: homing is under way"
        if not self.is_homed:
            return f"{what} refused: the arm is not homed (send home first)"
        return None


__all__ = ["DISABLED", "ENABLED", "FAULT", "PAUSED", "STATE_COMMANDS", "ArmState", "Transition"]
