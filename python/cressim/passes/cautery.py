"""An energized tool tip (cautery.hlsl): per env, a tip (a point in one rigid body, the tool's
electrode, or a fixed point in the world), a radius, a power and a mode. While an env's cautery is
on, the engine's heat source of that env sits at the tip and puts the power into the tissue within
the radius (bodies with a cressim.Thermal; docs/particles.md, "Heat"); off, it puts none. In cut
mode it also parts the tissue it has coagulated there (coagulation mode only heats).

Commands live on the GPU (`commands`, int32 (envs, 4): x 1 on / 0 off, y the body (-1: none), z 1
cut mode / 0 coagulation;
`powers`, float32 (envs,): W while on), so a task pass can switch the cautery and set its power
itself (bind `commands` as `RWStructuredBuffer<int4> cauteries`); the host writes them only when it
drives the cautery (`set`, `set_power`). Run `execute()` before `step_physics()`: the source acts in
that step.
"""
from __future__ import annotations

import numpy as np

import cressim

from . import EnvTool, body_rows, source

POWER = 30.0  # W: a monopolar coagulation setting


class Cautery(EnvTool):
    def __init__(self, engine: cressim.Engine, body_entities, tip, radius: float, *, power: float = POWER,
                 name: str = "cautery"):
        """`body_entities`: each env's body (entity or id) carrying the tip, in env order, or None
        (the tip in the world); `tip`: the point in that body's frame (m; one for all envs, or one
        per env); `radius` (m): the tissue this near the tip takes the power; `power` (W, >= 0)."""
        if not (engine.buffer("particles.heat_capacities").read() > 0).any():
            raise ValueError("Cautery: nothing in the world takes heat (give a SoftBody a cressim.Thermal)")
        envs = engine.buffer("particles.env_ranges").shape[0]
        if not (np.isfinite(radius) and radius > 0):
            raise ValueError(f"Cautery: radius must be positive, got {radius}")
        bodies = np.full(envs, -1, dtype=np.int32)
        if body_entities is not None:
            bodies[:] = body_rows(engine, body_entities, "Cautery")
        tips = np.broadcast_to(np.asarray(tip, dtype=np.float32), (envs, 3))
        if not np.isfinite(tips).all():
            raise ValueError(f"Cautery: tip must be finite, got {tip}")
        powers = _powers(power, envs)
        super().__init__(engine, name, bodies)
        self.tips = engine.create_shared_buffer(f"{name}_tips", (envs, 4), "float32")
        self.tips.write(np.concatenate([tips, np.full((envs, 1), radius, np.float32)], axis=1))
        self.powers = engine.create_shared_buffer(f"{name}_powers", (envs,), "float32")
        self.powers.write(powers)
        rigid = "rigid.positions" in engine.internal_keys  # a world without rigid bodies: the tips stand in
        self.compute_pass = engine.create_compute_pass(
            source("cautery"), name="passes/cautery.hlsl", threads=envs, constants={"envs": envs},
            bindings={"body_positions": "rigid.positions" if rigid else self.tips,
                      "body_rotations": "rigid.rotations" if rigid else self.tips,
                      "cautery_tips": self.tips, "cautery_powers": self.powers, "cauteries": self.commands,
                      "sources": "control.heat_sources"})

    def set_mode(self, cut) -> None:
        """Each env's mode (bools, one per env, or one for all): cut (True) or coagulation."""
        state = self.commands.read()
        state[:, 2] = np.broadcast_to(np.asarray(cut, dtype=bool), (self.envs,))
        self.commands.write(state)

    def set_power(self, power) -> None:
        """Each env's power while on (W, finite, >= 0; one for all envs or one per env)."""
        self.powers.write(_powers(power, self.envs))


def _powers(power, envs: int) -> np.ndarray:
    p = np.broadcast_to(np.asarray(power, dtype=np.float64), (envs,))
    bad = ~(np.isfinite(p) & (p >= 0))
    if bad.any():
        env = int(np.nonzero(bad)[0][0])
        raise ValueError(f"Cautery: power of env {env} must be finite and >= 0, got {p[env]:g}")
    return p.astype(np.float32)
