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

from . import TipTool, per_env, source

POWER = 30.0  # W: a monopolar coagulation setting


class Cautery(TipTool):
    def __init__(self, engine: cressim.Engine, body_entities, tip, radius: float, *, power: float = POWER,
                 name: str = "cautery"):
        """`body_entities`: each env's body (entity or id) carrying the tip, in env order, or None
        (the tip in the world); `tip`: the point in that body's frame (m; one for all envs, or one
        per env); `radius` (m): the tissue this near the tip takes the power; `power` (W, >= 0)."""
        if not (engine.buffer("particles.heat_capacities").read() > 0).any():
            raise ValueError("Cautery: nothing in the world takes heat (give a SoftBody a cressim.Thermal)")
        envs = engine.buffer("particles.env_ranges").shape[0]
        powers = per_env(power, envs, "Cautery: power")  # before any buffer is made: a bad call leaves none
        super().__init__(engine, name, body_entities, tip, radius, "Cautery")
        self.powers = engine.create_shared_buffer(f"{name}_powers", (envs,), "float32")
        self.powers.write(powers)
        self.compute_pass = engine.create_compute_pass(
            source("cautery"), name="passes/cautery.hlsl", threads=envs, constants={"envs": envs},
            bindings={**self.tip_bindings, "cautery_tips": self.tips, "cautery_powers": self.powers,
                      "cauteries": self.commands, "sources": "control.heat_sources"})

    def set_mode(self, cut) -> None:
        """Each env's mode (bools, one per env, or one for all): cut (True) or coagulation."""
        state = self.commands.read()
        state[:, 2] = np.broadcast_to(np.asarray(cut, dtype=bool), (self.envs,))
        self.commands.write(state)

    def set_power(self, power) -> None:
        """Each env's power while on (W, finite, >= 0; one for all envs or one per env)."""
        self.powers.write(per_env(power, self.envs, "Cautery: power"))
