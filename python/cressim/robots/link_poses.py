"""URDF links posed on the GPU (link_poses.hlsl): every env's kinematic link bodies moved to the
forward kinematics of that env's joint values in one dispatch.

The steps are the compiled chain's (cressim.robots.chain, `Chain.steps`: each moving joint on a
link's way from the base, fixed joints folded into its origin, its type and axis, and where its
value comes from: gain x column + offset, which covers mimic joints).
`joint_values` ((envs, columns) float32, a shared buffer) holds the inputs; the host writes it
(`ArmBodies.write`) or a task pass does (bind it by name), then `execute()` records the dispatch
in the current frame, before `step_physics()`.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .chain import Chain


class LinkPoses:
    """The pass that poses `links` (URDF names) of every env from `joint_values`."""

    def __init__(self, engine, chain: Chain, links, rows, base_position, base_rotation, *, name: str = "arm"):
        """`chain`: its sources are joint_values' columns; `rows`: (envs, len(links)) body rows;
        `base_position` (m) and `base_rotation` (xyzw): the arm's base in each env's frame."""
        rows = np.asarray(rows, np.uint32)
        envs, count = rows.shape
        if count != len(links):
            raise ValueError(f"LinkPoses: {count} body rows per env for {len(links)} links")
        steps, ranges = chain.steps(links)
        self.engine, self.envs, self.columns, self.count = engine, envs, len(chain.sources), count
        self.joint_values = engine.create_shared_buffer(f"{name}_joint_values", (envs, self.columns), "float32")
        self.compute_pass = None
        if count == 0:
            return
        buffers = {"steps": (steps.reshape(-1, 4), "float32"), "link_steps": (ranges, "uint32"),
                   "link_rows": (rows.reshape(-1), "uint32")}
        bindings = {"joint_values": self.joint_values, "target_positions": "control.body_target_positions",
                    "target_rotations": "control.body_target_rotations"}
        for key, (data, dtype) in buffers.items():
            buffer = engine.create_shared_buffer(f"{name}_{key}", data.shape, dtype)
            buffer.write(data)
            bindings[key] = buffer
        self.compute_pass = engine.create_compute_pass(
            Path(__file__).with_name("link_poses.hlsl").read_text(), name=str(Path(__file__).with_name("link_poses.hlsl")),
            threads=envs * count, bindings=bindings,
            constants={"envs": envs, "links": count, "columns": self.columns,
                       "base_position": (*map(float, base_position), 0.0),
                       "base_rotation": tuple(float(v) for v in base_rotation)})

    def execute(self) -> None:
        """Records the dispatch in the current frame (before step_physics)."""
        if self.count:
            self.engine.execute_compute_pass(self.compute_pass)
