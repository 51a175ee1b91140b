"""SoftBodyPush: a kinematic capsule pushes a soft cube into a target region (../shared/TASKS.md), z up.

Workload, as published (the paper's y-up frame turned to z up, so its x-z plane is our x-y):
4 substeps; soft internal iterations 32; ground box half-extents (1.25, 0.85, 0.05); soft cube
0.45 m a side on a regular grid (here 7 particles an axis, spacing 0.075), particle radius 0.04,
mass 0.01, volume compliance 8e-4, damping 0.35, self-collision on; kinematic capsule pusher
r 0.10, half-height 0.18, upright. Action (2) moves the pusher in the plane. Obs (5): pusher x,
pusher y - target y, soft centroid x, centroid y - target y, fraction of particles in the target
box (centre x 0.45, half-extents 0.18, 0.18, 0.3). Reward: occupancy + 0.25 max(0, 1 - 2 x
centroid distance); terminated at occupancy >= 0.7; truncated at 180 steps.

Soft contacts (particle-particle and particle-collider) are solved in 16 of the 32 iterations,
as the paper's "soft contact 16". Not published, chosen here: distance compliance 8e-4 like the
volume's; pusher speed 1 m/s per
unit action, its start at x -0.6; the cube starts at the origin; no randomisation at reset.
Note: the undeformed cube is wider than the target (0.45 vs 0.36 m), so at most 5 x 5 of its
7 x 7 particle columns fit (occupancy 0.51; measured 0.51 pushing straight through); reaching
0.7 takes squeezing it, and most episodes end by truncation.
"""
from __future__ import annotations

from pathlib import Path

import cressim

from .particle_task import ParticleTask
from .vector_env import box

GROUND = (1.25, 0.85, 0.05)
CUBE_HALF = 0.225
PUSHER = (0.10, 0.18)  # radius, half height
TARGET = (0.45, 0.0, 0.18, 0.18, 0.3)  # centre x, y; half extents x, y, z


class SoftBodyPush(ParticleTask):
    hlsl = Path(__file__).with_name("soft_body_push.hlsl")
    group_entries = ("evaluate", "observe")  # a thread group an env sums its particles
    single_observation_space = box((5,))
    single_action_space = box((2,), -1.0, 1.0)
    max_episode_steps = 180
    particle_iterations = 32
    contact_iterations = 16
    cells = 6  # per axis: 7 particles an axis
    pusher_speed = 1.0  # m/s per unit action
    success_occupancy = 0.7
    pusher_start = (-0.6, 0.0)  # x, y
    video_view = ((0.0, -2.6, 1.6), (0.1, 0.0, 0.2))

    def build_world(self, num_envs: int) -> cressim.World:
        world = cressim.World(cressim.SceneLayout(num_envs))
        mesh = cressim.TetMesh.box((CUBE_HALF,) * 3, (self.cells,) * 3)
        self.particles_per_env = len(mesh.positions)
        if self.render_mode is not None:  # visuals in the envs render() shows
            ground_mesh = world.add_mesh(cressim.Mesh.box(GROUND))
            pusher_mesh = world.add_mesh(cressim.Mesh.capsule(*PUSHER))
        for env in range(num_envs):
            ground = world.create_entity(env=env, name="ground")
            ground.add(cressim.Transform(position=(0, 0, -GROUND[2])))
            ground.add(cressim.Collider(cressim.Shape.box(GROUND)))
            pusher = world.create_entity(env=env, name="pusher")
            pusher.add(cressim.Transform(position=(*self.pusher_start, PUSHER[1] + PUSHER[0] + 0.01)))
            pusher.add(cressim.RigidBody(kinematic=True))
            pusher.add(cressim.Collider(cressim.Shape.capsule(*PUSHER)))
            if self.rendered(env):
                ground.add(cressim.Renderable(ground_mesh, color=(0.4, 0.45, 0.4, 1)))
                pusher.add(cressim.Renderable(pusher_mesh, color=(0.2, 0.35, 0.75, 1)))
            cube = world.create_entity(env=env, name="cube")
            cube.add(cressim.Transform(position=(0, 0, CUBE_HALF + 0.04)))
            cube.add(cressim.SoftBody(mesh, mass=0.01, radius=0.04, distance_compliance=8e-4, volume_compliance=8e-4,
                                      damping=0.35, self_collision=True))
        return world

    def task_constants(self, reset_all: bool) -> dict:
        return {"envs": self.num_envs, "max_steps": self.max_episode_steps, "reset_all": int(reset_all),
                "step_length": self.pusher_speed / 60, "target_x": TARGET[0], "target_y": TARGET[1],
                "target_half_x": TARGET[2], "target_half_y": TARGET[3], "target_height": 2 * TARGET[4],
                "success": self.success_occupancy, "limit_x": GROUND[0], "limit_y": GROUND[1]}
