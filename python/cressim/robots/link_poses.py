"""URDF links posed on the GPU (link_poses.hlsl): every env's kinematic link bodies moved to the
forward kinematics of that env's joint values in one dispatch.

The chain is compiled once into steps (each joint on a link's path from the root: its origin, its
type and axis, and where its value comes from: gain x column + offset, which covers mimic joints).
`joint_values` ((envs, columns) float32, a shared buffer) holds the inputs; the host writes it
(`ArmBodies.write`) or a task pass does (bind it by name), then `execute()` records the dispatch
in the current frame, before `step_physics()`.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .kinematics import rotation_xyzw

FIXED, REVOLUTE, PRISMATIC = 0, 1, 2
_TYPES = {"fixed": FIXED, "revolute": REVOLUTE, "continuous": REVOLUTE, "prismatic": PRISMATIC}


def chain_steps(urdf, links, sources) -> tuple[np.ndarray, np.ndarray]:
    """Steps ((S, 4, 4) float32) and each link's (first step, count) ((L, 2) uint32) for the URDF
    links `links`; `sources` names the joint of each column of joint_values (mimic joints read
    their source's column)."""
    joints = {j.name: j for j in urdf.robot.joints}
    parent_joint = {j.child: j for j in urdf.robot.joints}
    steps, ranges = [], []
    for link in links:
        path, name = [], link
        while name in parent_joint:
            path.append(parent_joint[name])
            name = parent_joint[name].parent
        first = len(steps)
        for j in reversed(path):
            kind = _TYPES.get(j.type)
            if kind is None:
                raise ValueError(f"URDF joint {j.name}: type {j.type!r} is not fixed, revolute, continuous or prismatic")
            origin = j.origin if j.origin is not None else np.eye(4)
            step = np.zeros((4, 4), np.float32)
            step[0, :3], step[0, 3] = origin[:3, 3], kind
            step[1] = rotation_xyzw(origin[:3, :3])
            if kind != FIXED:
                axis = np.asarray(j.axis if j.axis is not None else (1.0, 0.0, 0.0), np.float64)
                mimic = j.mimic
                source, gain, offset = (mimic.joint, mimic.multiplier or 1.0, mimic.offset or 0.0) if mimic \
                    else (j.name, 1.0, 0.0)
                if source not in sources:
                    raise ValueError(f"URDF joint {j.name} (on the path to {link}) moves with {source}, which is "
                                     f"not one of the arm's joints {', '.join(sources)}")
                step[2, :3], step[2, 3] = axis / np.linalg.norm(axis), gain
                step[3, 0], step[3, 1] = sources.index(source), offset
            steps.append(step)
        ranges.append((first, len(steps) - first))
    if links and not steps:
        steps.append(np.zeros((4, 4), np.float32))  # links at the root: an unused step keeps the buffer non-empty
    return np.asarray(steps, np.float32).reshape(-1, 4, 4), np.asarray(ranges, np.uint32).reshape(-1, 2)


class LinkPoses:
    """The pass that poses `links` (URDF names) of every env from `joint_values`."""

    def __init__(self, engine, urdf, links, sources, rows, base_position, base_rotation, *, name: str = "arm"):
        """`rows`: (envs, len(links)) body rows; `base_position` (m) and `base_rotation` (xyzw):
        the arm's base in each env's frame."""
        rows = np.asarray(rows, np.uint32)
        envs, count = rows.shape
        if count != len(links):
            raise ValueError(f"LinkPoses: {count} body rows per env for {len(links)} links")
        steps, ranges = chain_steps(urdf, links, list(sources))
        self.engine, self.envs, self.columns, self.count = engine, envs, len(sources), count
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
