"""What every instrument plug-in of a TwinArms has: hooks around the tick's one engine frame.

An instrument is one function of the tool an arm carries (the jaws' grasp, a needle in them,
suction, cautery, the contact wrench), batched over the arms' rows. `build(arms)` makes it where
the arm's tool and world have what it needs (None otherwise); the tick calls `before_step(arms)`
(the GPU pass's inputs from the measured state) and `after_step(arms)` (what the frame did) around
the frame; `reset(arms, envs)` puts rows back as authored (a reset, a physics fault) and
`restart(arms)` every row as the twin started. `commands` maps a client command's kind
(`suction/servo_jp`) to the method that takes it (`fn(arms, env, value) -> events`); a command
for an instrument the arm lacks is answered by the class's `absent(arms, env, kind, value)`.
`fields(arms)` is what the instrument adds to a tick's snapshot ((N, width) tensors by name).
"""
from __future__ import annotations

from ..messages import Event


class Instrument:
    name = ""
    commands: dict = {}

    @classmethod
    def build(cls, arms) -> "Instrument | None":
        raise NotImplementedError

    @classmethod
    def absent(cls, arms, env: int, kind: str, value) -> list[Event]:
        return [Event(env, "error", f"{kind} refused: the {arms.robot} instrument has no {cls.name}")]

    def before_step(self, arms) -> None:
        pass

    def after_step(self, arms) -> None:
        pass

    def reset(self, arms, envs) -> None:
        pass

    def restart(self, arms) -> None:
        pass

    def fields(self, arms) -> dict:
        return {}


def jaws_closed(arms):
    """(N,) bool: each row's measured jaw angle below the grasp's `closed_below`."""
    return (arms.jaw_meas[:, 0] < arms.scene.grasp_closed_below).numpy()


__all__ = ["Instrument", "jaws_closed"]
