"""FluidPour: tilt and move a source container to pour fluid into a target one (../shared/TASKS.md), z up.

Workload, as published (the paper's y-up frame turned to z up): two open boxes of inner
half-extents (1.15, 0.80, 0.95) (x, y, height) with walls 0.24 thick, a kinematic source and a
static target; 960 fluid particles per env (a 12 x 8 x 10 block, radius 0.09, spacing 0.18,
rest density 1000) with viscosity, cohesion, surface tension and vorticity confinement on.
Action (2): source x and tilt (up to 90 deg, pouring toward +x). Obs (6): source x, tilt, fluid
centroid x and height, fraction in the target, fraction spilled. Reward: target fraction -
spill penalty x spilled fraction; terminated at 0.40 caught; truncated at 240 steps.

Not published, chosen here: 4 substeps and 4 particle iterations; the source at x -1.7 with its
floor 1.2 m up, the target at x +1.7 on a ground plane; actions are rates (0.02 m and 1.5 deg per
step and unit action), source x within [-2.2, -1.2]; fluid coefficients XSPH 0.01, cohesion 0.05,
surface tension 0.05, vorticity 0.01; spill penalty 1; spilled = on the ground outside the target.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

import cressim

from .particle_task import ParticleTask
from .vector_env import box

INNER = (1.15, 0.80, 0.95)  # half extents x, y, and half height
WALL = 0.12  # half thickness
SOURCE = (-1.7, 0.0, 1.2)  # inner floor centre
TARGET = (1.7, 0.0, 2 * WALL)
RADIUS = 0.09
BLOCK = (12, 8, 10)


def open_box_parts() -> list:
    """Floor and four walls, (half extents, centre), of an open box whose inner floor centre is the
    entity origin."""
    ix, iy, ih = INNER
    w = WALL
    return [((ix + 2 * w, iy + 2 * w, w), (0, 0, -w)), ((w, iy + 2 * w, ih), (ix + w, 0, ih)),
            ((w, iy + 2 * w, ih), (-ix - w, 0, ih)), ((ix, w, ih), (0, iy + w, ih)), ((ix, w, ih), (0, -iy - w, ih))]


def open_box_shapes():
    return [cressim.Shape.box(half, position=centre) for half, centre in open_box_parts()]


def open_box_mesh() -> cressim.Mesh:
    """The open box as one mesh (its parts' faces, flat-shaded), for the rendered envs."""
    positions, normals, triangles = [], [], []
    for half, centre in open_box_parts():
        for axis in range(3):
            for sign in (-1.0, 1.0):  # a face: 4 corners, its normal along +-axis
                n = np.zeros(3)
                n[axis] = sign
                u, v = np.eye(3)[(axis + 1) % 3], np.eye(3)[(axis + 2) % 3]
                corners = [n + a * u + b * v for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
                first = len(positions)
                positions += [np.asarray(centre) + np.asarray(half) * c for c in corners]
                normals += [n] * 4
                quad = [(0, 1, 2), (0, 2, 3)] if sign > 0 else [(0, 2, 1), (0, 3, 2)]  # counter-clockwise outside
                triangles += [[first + i for i in t] for t in quad]
    return cressim.Mesh(np.asarray(positions, np.float32), np.asarray(triangles, np.uint32),
                        np.asarray(normals, np.float32))


class FluidPour(ParticleTask):
    hlsl = Path(__file__).with_name("fluid_pour.hlsl")
    group_entries = ("evaluate", "observe")  # a thread group an env sums its particles
    single_observation_space = box((6,))
    single_action_space = box((2,), -1.0, 1.0)
    max_episode_steps = 240
    particle_iterations = 4
    spill_penalty = 1.0
    success_fraction = 0.40
    video_view = ((0.0, -10.0, 5.0), (0.0, 0.0, 1.0))

    def build_world(self, num_envs: int) -> cressim.World:
        world = cressim.World(cressim.SceneLayout(num_envs))
        d = 2 * RADIUS
        n = BLOCK
        z, y, x = np.meshgrid(np.arange(n[2]), np.arange(n[1]), np.arange(n[0]), indexing="ij")
        block = np.stack([x, y, z], -1).reshape(-1, 3) * d
        block = (block - [(n[0] - 1) * d / 2, (n[1] - 1) * d / 2, -RADIUS - 0.01]).astype(np.float32)
        if self.render_mode is not None:  # visuals in the envs render() shows
            box_mesh, ground_mesh = world.add_mesh(open_box_mesh()), world.add_mesh(cressim.Mesh.plane(4.0))
        for env in range(num_envs):
            ground = world.create_entity(env=env, name="ground")
            ground.add(cressim.Transform())
            ground.add(cressim.Collider(cressim.Shape.plane()))
            source = world.create_entity(env=env, name="source")
            source.add(cressim.Transform(position=SOURCE))
            source.add(cressim.RigidBody(kinematic=True))
            source.add(cressim.Collider(open_box_shapes()))
            target = world.create_entity(env=env, name="target")
            target.add(cressim.Transform(position=TARGET))
            target.add(cressim.Collider(open_box_shapes()))
            if self.rendered(env):
                ground.add(cressim.Renderable(ground_mesh, color=(0.4, 0.45, 0.4, 1)))
                for box in (source, target):
                    box.add(cressim.Renderable(box_mesh, color=(0.75, 0.75, 0.8, 1)))
            water = world.create_entity(env=env, name="water")
            water.add(cressim.Transform(position=SOURCE))
            water.add(cressim.Fluid(block, radius=RADIUS, rest_density=1000, viscosity=0.01, cohesion=0.05,
                                    surface_tension=0.05, vorticity=0.01))
        self.particles_per_env = len(block)
        return world

    def task_bindings(self) -> dict:
        return {**super().task_bindings(), "body_rotations": "rigid.rotations",
                "target_rotations": "control.body_target_rotations"}

    def task_constants(self, reset_all: bool) -> dict:
        return {"envs": self.num_envs, "max_steps": self.max_episode_steps, "reset_all": int(reset_all),
                "move_step": 0.02, "tilt_step": math.radians(1.5), "max_tilt": math.radians(90),
                "min_x": -2.2, "max_x": -1.2, "target_x": TARGET[0], "target_y": TARGET[1], "target_floor": TARGET[2],
                "inner_x": INNER[0], "inner_y": INNER[1], "inner_height": 2 * INNER[2],
                "spill_penalty": self.spill_penalty, "success": self.success_fraction}
