"""CartPole: the paper's rigid-body benchmark task (../shared/TASKS.md), z up.

Workload, as published: static rail box half-extents (2.5, 0.04, 0.04); cart box (0.18, 0.1, 0.1),
1 kg, on a slider along x with limits +-2.4 and a target-velocity drive (action x 8 m/s); pole
box (0.05, 0.5, 0.05) in the paper's y-up frame, here (0.05, 0.05, 0.5) along z, 2 kg, on a hinge
0.1 above the cart centre and 0.5 below the pole centre; no collisions between the parts.
Frame time 1/60 s. Observations (4): cart x, cart velocity, pole angle, pole angular velocity.
Reward 1 per step; terminated when |x| > 2.4 or |angle| > 12 deg; truncated at 500 steps;
reset uniform in +-0.05 for each observed quantity.

Not published, chosen here: 4 substeps and 1 iteration per substep; the drive's damping
1e4 N s/m with a 1000 N force limit (the cart follows the commanded velocity within a substep
or two); hinge about y.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

import cressim

from .vector_env import box, VectorEnv

RAIL = (2.5, 0.04, 0.04)
CART = (0.18, 0.1, 0.1)
POLE = (0.05, 0.05, 0.5)


class CartPole(VectorEnv):
    hlsl = Path(__file__).with_name("cartpole.hlsl")
    single_observation_space = box((4,))
    single_action_space = box((1,), -1.0, 1.0)
    max_episode_steps = 500
    action_scale = 8.0
    max_x = 2.4
    max_angle = math.radians(12)
    reset_range = 0.05

    video_view = ((0.0, -6.5, 1.2), (0.0, 0.0, 0.4))

    def build_world(self, num_envs: int) -> cressim.World:
        world = cressim.World(cressim.SceneLayout(num_envs))
        no_contacts = dict(group=0, mask=0)
        looks = {}  # the parts' visuals, only in the envs render() shows
        if self.render_mode is not None:
            looks = {part: (world.add_mesh(cressim.Mesh.box(size)), colour) for part, size, colour in (
                ("rail", RAIL, (0.3, 0.3, 0.32, 1)), ("cart", CART, (0.15, 0.35, 0.8, 1)),
                ("pole", POLE, (0.85, 0.55, 0.1, 1)))}
        for env in range(num_envs):
            rail = world.create_entity(env=env, name="rail")
            rail.add(cressim.Transform())
            rail.add(cressim.Collider(cressim.Shape.box(RAIL), **no_contacts))
            cart = world.create_entity(env=env, name="cart")
            cart.add(cressim.Transform())
            cart.add(cressim.RigidBody(mass=1.0))
            cart.add(cressim.Collider(cressim.Shape.box(CART), **no_contacts))
            pole = world.create_entity(env=env, name="pole")
            pole.add(cressim.Transform(position=(0, 0, 0.6)))
            pole.add(cressim.RigidBody(mass=2.0))
            pole.add(cressim.Collider(cressim.Shape.box(POLE), **no_contacts))
            if self.rendered(env):
                for entity, (mesh, colour) in zip((rail, cart, pole), looks.values()):
                    entity.add(cressim.Renderable(mesh, color=colour))
            world.create_entity(env=env, name="cart_slider").add(cressim.Joint(
                "slider", body_b=cart, axis=(1, 0, 0), limits=(-self.max_x, self.max_x), drive="velocity",
                damping=1e4, max_force=1000.0))
            world.create_entity(env=env, name="pole_hinge").add(cressim.Joint(
                "hinge", body_a=cart, body_b=pole, anchor=(0, 0, 0.1), axis=(0, 1, 0)))
        return world

    def physics_settings(self) -> cressim.PhysicsSettings:
        # the parts never collide: no contact scratch
        return cressim.PhysicsSettings(dt=1 / 60, substeps=4, iterations=1, gravity=(0, 0, -9.81),
                                       max_contacts_per_env=0)

    def task_bindings(self) -> dict:
        # joints are stored per env, parent before child: the slider (on the world), then the hinge
        m = self.engine.mapping
        joint_env = m["env_index"][m["entity_row"][self.engine.buffer("joint.entity").read()]]
        assert (joint_env == np.repeat(np.arange(self.num_envs), 2)).all(), "unexpected joint layout"
        assert self.engine.world.entity(int(self.engine.buffer("joint.entity").read()[0])).name == "cart_slider"
        task_joints = self.engine.create_shared_buffer("task_joints", 2 * self.num_envs, "uint32")
        task_joints.write(np.arange(2 * self.num_envs, dtype=np.uint32))
        return {"task_joints": task_joints, "joint_positions": "joint.positions",
                "joint_velocities": "joint.velocities", "reset_count": "env.reset_count",
                "joint_targets": "control.joint_targets", "joint_reset": "control.joint_reset"}

    def task_constants(self, reset_all: bool) -> dict:
        return {"envs": self.num_envs, "max_steps": self.max_episode_steps, "seed": self.seed,
                "action_scale": self.action_scale, "max_x": self.max_x, "max_angle": self.max_angle,
                "reset_range": self.reset_range, "reset_all": int(reset_all)}
