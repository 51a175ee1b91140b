"""Suction of fluid (blood) at a tool's tip (suction.hlsl): per env, a tip (a point in one rigid
body, the suction tube's end, or a fixed point in the world) and a radius; while an env's suction
is on, its active fluid particles within the radius are removed at the next step's start and
counted.

Commands live on the GPU (`commands`, int32 (envs, 4): x 1 on / 0 off, y the body (-1: none),
w particles removed so far), so a task pass can switch suction itself (bind `commands` as
`RWStructuredBuffer<int4> suctions`); the host writes them only when it drives the suction
(`set`). Run `execute()` after `step_physics()` of a frame (or before it): the removals apply at
the next step's start.
"""
from __future__ import annotations

import numpy as np

import cressim

from . import EnvTool, body_rows, source


class Suction(EnvTool):
    def __init__(self, engine: cressim.Engine, body_entities, tip, radius: float, *, name: str = "suction"):
        """`body_entities`: each env's body (entity or id) carrying the tip, in env order, or None
        (the tip in the world); `tip`: the point in that body's frame (m; one for all envs, or one
        per env); `radius` (m)."""
        envs = engine.buffer("particles.env_ranges").shape[0]
        if not (np.isfinite(radius) and radius > 0):
            raise ValueError(f"Suction: radius must be positive, got {radius}")
        bodies = np.full(envs, -1, dtype=np.int32)
        if body_entities is not None:
            bodies[:] = body_rows(engine, body_entities, "Suction")
        tips = np.broadcast_to(np.asarray(tip, dtype=np.float32), (envs, 3))
        if not np.isfinite(tips).all():
            raise ValueError(f"Suction: tip must be finite, got {tip}")
        super().__init__(engine, name, bodies)
        self.tips = engine.create_shared_buffer(f"{name}_tips", (envs, 4), "float32")
        self.tips.write(np.concatenate([tips, np.full((envs, 1), radius, np.float32)], axis=1))
        count = engine.buffer("particles.positions").shape[0]
        rigid = "rigid.positions" in engine.internal_keys  # a world without rigid bodies: the tips stand in
        self.compute_pass = engine.create_compute_pass(
            source("suction"), name="passes/suction.hlsl", threads=count, constants={"count": count},
            bindings={"positions": "particles.positions", "phases": "particles.phases",
                      "body_positions": "rigid.positions" if rigid else self.tips,
                      "body_rotations": "rigid.rotations" if rigid else self.tips,
                      "suction_tips": self.tips, "suctions": self.commands, "remove": "control.particle_remove"})

    def removed(self) -> np.ndarray:
        """Fluid particles each env's suction has removed so far."""
        return self.count()
