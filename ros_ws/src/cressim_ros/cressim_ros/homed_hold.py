"""Holds back the operating_state that answers `home` until the arm's state topics have readers.

Why. A client homes an arm and at once reads its state: the dVRK's dvrk_teleoperation.py calls
`puppet.home()` and then `puppet.setpoint_cp()`, and crtk raises "no data received yet" when no
setpoint_cp sample has reached it. DDS discovers each endpoint on its own, so the client's
operating_state reader can be matched (and told "homed") while its setpoint_cp reader is not yet
(on a loaded machine, late). So the operating_state that says the arm is homed (ENABLED,
is_homed, not busy, after a `home`) waits until each of the arm's periodic state publishers
(STATE_TOPICS) has had at least as many matched readers as its operating_state publisher when
the samples of the last two ticks went out: a client that reads all of them has had a sample of
each a tick before it is told. The twin's loop goes on meanwhile; the counts are read each tick,
only for arms that are homing or held.

The counts cannot tell a client that reads only operating_state (or a subset, or an observer
of operating_state alone) from one whose readers are late, so the hold is bounded by LIMIT_NS of
simulated time, counted tick by tick (a paused simulation keeps it; a clock reset does not
stretch it): 1 s, 100 ticks at the dVRK's 100 Hz, meant to outlast endpoint discovery on a
loaded machine (where the twin also runs slower than real time, so the bound grows in wall time
with the load), and short enough for the dVRK clients' wall-clock homing timeout (10 s per
arm in dvrk_teleoperation.py) with the twin at a quarter of its rate (the teleoperation test on
2 loaded cores ran it at about 45 ticks/s).

While an arm's answer is held, its later operating_state messages queue behind it (a new
reader's repeat of the same state) or, when its state changed (a move, `disable`), go out right
after it, in order.
"""
from __future__ import annotations

from typing import Callable, Hashable

STATE_TOPICS = ("measured_js", "setpoint_js", "measured_cp", "setpoint_cp")
LIMIT_NS = 1_000_000_000
READY_TICKS = 2  # ticks whose samples went out to every reader before the answer does


def is_homed_answer(report) -> bool:
    """The state `home` waits for (crtk's: is_homed and not is_busy; ENABLED, which `home` sets)."""
    return report.state == "ENABLED" and report.is_homed and not report.is_busy


class HomedHold:
    """Per arm (any key): whether a `home` is under way, its held answer, and for how many ticks
    in a row the arm's state readers had caught up with its operating_state readers.

        hold.check(caught_up)                 # each tick, before its samples are published
        for topic, value in hold.admit(key, topic, value): publish ...   # every event of the arm
        for key, topic, value in hold.due(period_ns): publish ...        # each tick, after its samples
    """

    def __init__(self, limit_ns: int = LIMIT_NS):
        self.limit_ns = limit_ns
        self._homing = set()  # keys whose next homed operating_state answers a `home`
        self._ready = {}  # key -> ticks in a row caught up, since its `home`
        self._held = {}  # key -> [simulated ns left, [operating_state values, in order]]

    def check(self, caught_up: Callable[[Hashable], bool]):
        for key in self._homing | self._held.keys():
            self._ready[key] = self._ready.get(key, 0) + 1 if caught_up(key) else 0

    def admit(self, key, topic: str, value) -> list:
        """The (topic, value) events to publish now for this one of arm `key`: none while it is
        held, the held ones first when it ends a hold."""
        if topic == "desired_state" and value == "HOMED":
            self._homing.add(key)
            self._ready[key] = 0  # counted from the next tick's samples
            return [(topic, value)]
        if topic != "operating_state":
            return [(topic, value)]
        answer = key in self._homing and is_homed_answer(value)
        if key in self._homing and not value.is_busy:
            self._homing.discard(key)  # answered, or the homing ended otherwise (disable, unhome)
        held = self._held.get(key)
        if held is not None:
            if value == held[1][-1]:  # the same state again (a new reader's): after the held one
                held[1].append(value)
                return []
            del self._held[key]  # the state changed: what was held goes out first
            return [(topic, v) for v in held[1]] + [(topic, value)]
        if answer and self._ready.get(key, 0) < READY_TICKS:
            self._held[key] = [self.limit_ns, [value]]
            return []
        return [(topic, value)]

    def due(self, elapsed_ns: int) -> list:
        """(key, topic, value) of the held answers that go out now (published as they are, not
        admitted again): caught up for READY_TICKS ticks, or held limit_ns."""
        out = []
        for key in list(self._held):
            held = self._held[key]
            held[0] -= elapsed_ns
            if self._ready.get(key, 0) >= READY_TICKS or held[0] <= 0:
                del self._held[key]
                out += [(key, "operating_state", v) for v in held[1]]
        for key in [k for k in self._ready if k not in self._homing and k not in self._held]:
            del self._ready[key]
        return out

    def clear(self):
        """The arms were reset (DISABLED, not homed): nothing is answered any more."""
        self._homing.clear()
        self._ready.clear()
        self._held.clear()


def readers_caught_up(state_pubs: dict, operating_state_pub) -> bool:
    """Each of STATE_TOPICS' publishers (those there are) has as many matched readers as the
    operating_state publisher."""
    wanted = operating_state_pub.get_subscription_count()
    return all(state_pubs[t].get_subscription_count() >= wanted for t in STATE_TOPICS if t in state_pubs)


__all__ = ["HomedHold", "LIMIT_NS", "READY_TICKS", "STATE_TOPICS", "is_homed_answer", "readers_caught_up"]
