"""Grasping soft bodies and threads with a tool (grasp.hlsl): per env, a point fixed in one rigid
body (between the jaws) and a reach; closing the grasp attaches the movable soft-body and strand
particles within reach to the body where they are, nearest first, one per attachment slot of the
env (`PhysicsSettings.max_particle_attachments_per_env`); opening frees them.

Commands live on the GPU (`commands`, int32 (envs, 4): x 1 closed / 0 open, y the body, z state
0 open / 1 holding / 2 closed on nothing, w particles held), so a task pass can close and open
grasps itself (bind `commands` as `RWStructuredBuffer<int4> grasps`) and the host writes them only
when it drives the grasps (`set`). Run `execute()` before `step_physics()`: the attachments it
makes take effect in that step. An elastic particle held this way passes its load to the body's
`rigid.contact_forces`, so the tool reads the weight of what it lifts.
"""
from __future__ import annotations

import numpy as np

import cressim

from . import EnvTool, body_rows, source


class Grasp(EnvTool):
    def __init__(self, engine: cressim.Engine, body_entities, point, radius: float, *, name: str = "grasp"):
        """`body_entities`: the body (entity or its id) of each env's grasp, in env order; `point`: the
        grasp point in that body's frame (m; one for all envs, or one per env); `radius`: reach (m)."""
        envs = engine.buffer("particles.env_ranges").shape[0]
        slots = engine.buffer("control.particle_attachments").shape[0] // max(envs, 1)
        if slots == 0:
            raise ValueError("Grasp: no attachment slots (PhysicsSettings.max_particle_attachments_per_env = 0)")
        if not (np.isfinite(radius) and radius > 0):
            raise ValueError(f"Grasp: radius must be positive, got {radius}")
        bodies = body_rows(engine, body_entities, "Grasp")
        points = np.broadcast_to(np.asarray(point, dtype=np.float32), (envs, 3))
        if not np.isfinite(points).all():
            raise ValueError(f"Grasp: point must be finite, got {point}")
        super().__init__(engine, name, bodies)
        self.slots = slots
        self.points = engine.create_shared_buffer(f"{name}_points", (envs, 4), "float32")
        self.points.write(np.concatenate([points, np.full((envs, 1), radius, np.float32)], axis=1))
        self.compute_pass = engine.create_compute_pass(
            source("grasp"), name="passes/grasp.hlsl", threads=envs, constants={"envs": envs, "slots": slots},
            bindings={"positions": "particles.positions", "phases": "particles.phases",
                      "env_ranges": "particles.env_ranges", "body_positions": "rigid.positions",
                      "body_rotations": "rigid.rotations", "grasp_points": self.points, "grasps": self.commands,
                      "attachments": "control.particle_attachments"})

    def held(self) -> np.ndarray:
        """Particles each env's grasp holds (0 when open or closed on nothing)."""
        return self.count()
