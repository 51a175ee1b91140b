"""The PSM's links as kinematic bodies in a cressim engine, one arm per env.

Each URDF link with collision geometry becomes one kinematic rigid body whose colliders are
the link's collision primitives (cylinder -> capsule of the same radius and length, box,
sphere). Every tick the twin writes all envs' link poses into the engine's body targets in one
batched step: the full URDF chain's FK (pytorch-kinematics, mimic joints expanded by a matrix),
times the arm's base pose, scattered into `control.body_target_positions/rotations` through
a precomputed index. No per-env Python loop runs per tick.

The arm is kinematic on purpose: the twin reports setpoints and measured values from its own
joint state; the engine bodies follow so that contacts with other scene objects see the arm's
motion (and its speed: kinematic bodies cover their way in equal shares per substep).
"""
from __future__ import annotations

import numpy as np
import pytorch_kinematics as pk
import torch
import yourdfpy
from pytorch_kinematics.transforms import matrix_to_quaternion

import cressim

ARM_GROUP = 2  # collision group of arm links; they do not collide with each other (mask below)


def _rotation_xyzw(R: np.ndarray) -> tuple:
    q = matrix_to_quaternion(torch.as_tensor(R, dtype=torch.float64))  # w, x, y, z
    return (float(q[1]), float(q[2]), float(q[3]), float(q[0]))


def _shape(geometry, origin: np.ndarray):
    position, rotation = tuple(float(v) for v in origin[:3, 3]), _rotation_xyzw(origin[:3, :3])
    if geometry.box is not None:
        return cressim.Shape.box(tuple(float(s) / 2 for s in geometry.box.size), position=position, rotation=rotation)
    if geometry.cylinder is not None:  # a capsule as long as the cylinder, both along z
        r, length = float(geometry.cylinder.radius), float(geometry.cylinder.length)
        return cressim.Shape.capsule(r, max(length / 2 - r, 1e-4), position=position, rotation=rotation)
    if geometry.sphere is not None:
        return cressim.Shape.sphere(float(geometry.sphere.radius), position=position, rotation=rotation)
    return None  # meshes: the engine has no mesh colliders; the link is shown only


class ArmBodies:
    """num_envs arms (links as kinematic bodies) in one engine.

    joint order of `write`: the 6 interface joints (a 4-dof tool ignores the wrist ones),
    then the jaw.
    """

    def __init__(self, urdf_path, num_envs: int, *, base_position, base_rotation, publish_rate: float,
                 physics_rate: float, initial_q: np.ndarray, initial_jaw: float, dof: int, device=None):
        self.num_envs, self.dof = num_envs, dof
        urdf = yourdfpy.URDF.load(str(urdf_path), build_scene_graph=False, load_meshes=False)
        joints = {j.name: j for j in urdf.robot.joints}
        self.chain = pk.build_chain_from_urdf(open(urdf_path, "rb").read()).to(dtype=torch.float64)

        # chain joint values = interface values @ expand.T + shift (mimic joints follow theirs)
        # columns: the tool's arm joints, then the jaw (a column of zeros for a tool without one)
        sources = list(("yaw", "pitch", "insertion", "roll", "wrist_pitch", "wrist_yaw")[:dof]) + ["jaw"]
        chain_joints = self.chain.get_joint_parameter_names()
        expand = torch.zeros(len(chain_joints), dof + 1, dtype=torch.float64)
        shift = torch.zeros(len(chain_joints), dtype=torch.float64)
        for row, name in enumerate(chain_joints):
            mimic = joints[name].mimic
            source, gain = (mimic.joint, mimic.multiplier or 1.0) if mimic else (name, 1.0)
            expand[row, sources.index(source)] = gain
            shift[row] = (mimic.offset or 0.0) if mimic else 0.0
        self._expand, self._shift = expand, shift

        # links with collision geometry, and their shapes
        self.links, shapes = [], []
        for link in urdf.robot.links:
            link_shapes = [s for s in (_shape(c.geometry, c.origin if c.origin is not None else np.eye(4))
                                       for c in link.collisions) if s is not None]
            if link_shapes:
                self.links.append(link.name)
                shapes.append(link_shapes)

        base = np.eye(4)
        x, y, z, w = base_rotation
        base[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
        base[:3, 3] = base_position
        self.base = torch.as_tensor(base)

        q0 = torch.as_tensor(np.asarray(initial_q, dtype=np.float64)[None, :dof])
        start = self._link_poses(q0, torch.tensor([[initial_jaw]], dtype=torch.float64))[0]  # (L, 4, 4)
        world = cressim.World(cressim.SceneLayout(num_envs))
        entity_ids = []
        for env in range(num_envs):
            for name, link_shapes, T in zip(self.links, shapes, start):
                e = world.create_entity(env=env, name=name)
                e.add(cressim.Transform(position=tuple(float(v) for v in T[:3, 3]),
                                        rotation=_rotation_xyzw(T[:3, :3].numpy())))
                e.add(cressim.RigidBody(mass=0.1, kinematic=True))
                e.add(cressim.Collider(link_shapes, group=ARM_GROUP, mask=0xFFFFFFFF & ~ARM_GROUP))
                entity_ids.append(e.id)
        self.engine = cressim.Engine(world, device=device)
        substeps = int(round(physics_rate / publish_rate))
        self.engine.physics = cressim.PhysicsSettings(dt=1.0 / publish_rate, substeps=substeps, iterations=1,
                                                      gravity=(0.0, 0.0, -9.81))
        self.engine.prepare()
        self.engine.upload_world()

        self.target_p = torch.from_dlpack(self.engine.buffer("control.body_target_positions"))
        self.target_r = torch.from_dlpack(self.engine.buffer("control.body_target_rotations"))
        self.device = self.target_p.device
        if self.device.type == "cuda":  # frames wait for targets written on torch's stream
            self.engine.set_cuda_stream(torch.cuda.current_stream(self.device).cuda_stream)
        body_entity = np.asarray(self.engine.buffer("rigid.body_entity").read()).astype(np.int64)
        row_of_entity = {int(e): row for row, e in enumerate(body_entity)}
        # rows[env * L + link]: the body of that link in that env
        self.rows = torch.as_tensor([row_of_entity[e] for e in entity_ids], device=self.device)
        self.health = torch.from_dlpack(self.engine.buffer("env.health"))
        self._on = dict(device=self.device, dtype=torch.float64)
        self._expand, self._shift, self.base = (t.to(**self._on) for t in (self._expand, self._shift, self.base))
        self.chain = self.chain.to(**self._on)

    def _link_poses(self, q, jaw):
        """(N, dof), (N, 1) -> (N, L, 4, 4): link frames in the world (base pose applied)."""
        th = torch.cat([q[:, : self.dof], jaw], dim=-1) @ self._expand.T + self._shift
        frames = self.chain.forward_kinematics(th)
        T = torch.stack([frames[name].get_matrix() for name in self.links], dim=1)
        return self.base @ T

    def write(self, q: torch.Tensor, jaw: torch.Tensor):
        """Sets every env's link targets from joint values q (N, >= dof) and jaw (N, 1)."""
        T = self._link_poses(q.to(**self._on), jaw.to(**self._on)).reshape(-1, 4, 4)
        quat = matrix_to_quaternion(T[:, :3, :3])  # w, x, y, z
        self.target_p[self.rows, :3] = T[:, :3, 3].to(self.target_p.dtype)
        self.target_r[self.rows] = quat[:, [1, 2, 3, 0]].to(self.target_r.dtype)

    def step(self):
        """One publish period of physics (the engine runs its substeps), submitted and waited for."""
        self.engine.step_physics()
        self.engine.end_frame()

    def unhealthy_envs(self) -> list[int]:
        """Envs the solver flagged this frame (NaN, speed, penetration); they were reset."""
        bad = self.health.view(torch.int32) != 0
        return torch.nonzero(bad).flatten().tolist() if bool(bad.any()) else []


__all__ = ["ARM_GROUP", "ArmBodies"]
