"""Suction of fluid (blood) at a tool's tip (suction.hlsl): per env, a tip (a point in one rigid
body, the suction tube's end, or a fixed point in the world), a radius, a flow rate and a reach.
While an env's suction is on, its active fluid particles within the radius are removed at the
next step's start and counted, and the fluid within the reach flows toward the tip at least as
fast as a point sink at a wall draws it: Q / (2 pi r^2) at distance r (no faster than at the
radius, the tube's mouth), through the engine's per-env fluid sink (`control.fluid_sinks`).

Commands live on the GPU (`commands`, int32 (envs, 4): x 1 on / 0 off, y the body (-1: none),
w particles removed so far; `flows`, float32 (envs, 4): x flow rate m^3/s, y reach m), so a task
pass can switch suction and set its flow itself (bind `commands` as `RWStructuredBuffer<int4>
suctions`, `flows` as `suction_flows`); the host writes them only when it drives the suction
(`set`, `set_flow`). Run `execute()` before `step_physics()` of a frame: the sink acts in that
step, the removals at the next step's start.
"""
from __future__ import annotations

import numpy as np

import cressim

from . import TipTool, per_env, source


FLOW_RATE = 1e-3 / 60  # m^3/s: 1 L/min, a surgical suction clearing blood
REACH_RADII = 4.0  # the reach, in removal radii (the paper's pull within 1.0 unit, removal within 0.25)


class Suction(TipTool):
    def __init__(self, engine: cressim.Engine, body_entities, tip, radius: float, *, flow_rate: float = FLOW_RATE,
                 reach: float | None = None, name: str = "suction"):
        """`body_entities`: each env's body (entity or id) carrying the tip, in env order, or None
        (the tip in the world); `tip`: the point in that body's frame (m; one for all envs, or one
        per env); `radius` (m): fluid this near the tip is removed; `flow_rate` (m^3/s, >= 0): the
        sink's draw; `reach` (m, >= radius; default 4 radii): fluid this near is drawn in."""
        reach = REACH_RADII * radius if reach is None else reach
        if not (np.isfinite(reach) and reach >= radius):
            raise ValueError(f"Suction: reach must be at least the radius {radius}, got {reach}")
        super().__init__(engine, name, body_entities, tip, radius, "Suction")
        self.reach = float(reach)
        self.flows = engine.create_shared_buffer(f"{name}_flows", (self.envs, 4), "float32")
        self.set_flow(flow_rate)
        count = engine.buffer("particles.positions").shape[0]
        self.compute_pass = engine.create_compute_pass(
            source("suction"), name="passes/suction.hlsl", threads=max(count, self.envs),
            constants={"count": count, "envs": self.envs},
            bindings={"positions": "particles.positions", "phases": "particles.phases", **self.tip_bindings,
                      "suction_tips": self.tips, "suction_flows": self.flows, "suctions": self.commands,
                      "remove": "control.particle_remove", "sinks": "control.fluid_sinks"})

    def set_flow(self, rates) -> None:
        """Each env's flow rate (m^3/s, finite, >= 0; one for all envs or one per env)."""
        rates = per_env(rates, self.envs, "Suction: flow_rate")
        flows = np.zeros((self.envs, 4), np.float32)
        flows[:, 0], flows[:, 1] = rates, self.reach
        self.flows.write(flows)

    def removed(self) -> np.ndarray:
        """Fluid particles each env's suction has removed so far."""
        return self.count()
