"""TargetCenter: the paper's visual task (../shared/TASKS.md): turn a camera so that a cube
target sits in the middle of its image.

Workload, as published: a ground plane, a 0.2 m cube target, one directional light, one camera
per env (64x64 RGB, 50 deg fov). Action (2): camera yaw and pitch, 0.2 deg per step per unit.
Observation: the RGB image, (envs, H, W, 3) uint8. Reward: the decrease of the target's
normalised distance from the image centre (1 at the image's edge) - 0.01 per step, +1 on
success (distance <= 0.06), which ends the episode; truncated at 120 steps.

Not published, chosen here: the camera at (0, -1, 0.6) (z up); targets uniform on the ground in
x +-0.4, y 0..0.6; each episode starts aimed at the target, off by up to 8 deg in yaw and pitch
(within the 0.2 deg/step x 120 steps reach); the camera and the target are kinematic bodies that
the task pass moves (a physics step puts them where the task says), so a finished env starts its
next episode in the same step, and the next observation shows it.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import torch

import cressim

from .vector_env import VectorEnv, box, tensor_view

EYE = (0.0, -1.0, 0.6)
CUBE = 0.1  # half extent


class TargetCenter(VectorEnv):
    hlsl = Path(__file__).with_name("target_center.hlsl")
    single_action_space = box((2,), -1.0, 1.0)
    own_cameras = True  # render() shows the task's camera
    renders_cameras = True
    max_episode_steps = 120
    action_scale = math.radians(0.2)
    fov_y = 50.0
    success = 0.06
    start_offset = math.radians(8.0)

    def __init__(self, num_envs: int, *, image_size: int = 64, **kwargs):
        self.image_size = image_size
        self.single_observation_space = box((image_size, image_size, 3), 0, 255, np.uint8)
        super().__init__(num_envs, **kwargs)

    def build_world(self, num_envs: int) -> cressim.World:
        world = cressim.World(cressim.SceneLayout(num_envs, max_renderables_per_env=2, max_lights_per_env=1,
                                                  max_cameras_per_env=1))
        plane, cube = world.add_mesh(cressim.Mesh.plane(3.0)), world.add_mesh(cressim.Mesh.box((CUBE, CUBE, CUBE)))
        no_contacts = dict(group=0, mask=0)
        for env in range(num_envs):
            ground = world.create_entity(env=env, name="ground")
            ground.add(cressim.Transform())
            ground.add(cressim.Renderable(plane, color=(0.45, 0.5, 0.45, 1)))
            target = world.create_entity(env=env, name="target")
            target.add(cressim.Transform(position=(0, 0.3, CUBE)))
            target.add(cressim.RigidBody(mass=1.0, kinematic=True))
            target.add(cressim.Collider(cressim.Shape.box((CUBE, CUBE, CUBE)), **no_contacts))
            target.add(cressim.Renderable(cube, color=(0.9, 0.15, 0.1, 1)))
            camera = world.create_entity(env=env, name="camera")
            camera.add(cressim.Transform(position=EYE, rotation=(-math.sqrt(0.5), 0, 0, math.sqrt(0.5))))
            camera.add(cressim.RigidBody(mass=1.0, kinematic=True))
            camera.add(cressim.Collider(cressim.Shape.sphere(0.01), **no_contacts))
            camera.add(cressim.Camera(width=self.image_size, height=self.image_size, fov_y=self.fov_y, products=["rgb"]))
            sun = world.create_entity(env=env, name="sun")
            sun.add(cressim.Transform(rotation=(0.2, 0.1, 0.0, 0.97)))  # mostly downwards
            sun.add(cressim.Light(intensity=1.0, ambient=0.3))
        return world

    def physics_settings(self) -> cressim.PhysicsSettings:
        # kinematic bodies only: one substep reaches the targets exactly
        return cressim.PhysicsSettings(dt=1 / 60, substeps=1, iterations=1, max_contacts_per_env=0)

    # --- buffers and passes ----------------------------------------------------------------
    def _task_buffers(self) -> dict:
        e, n = self.engine, self.num_envs
        body_entity = e.buffer("rigid.body_entity").read()
        names = [e.world.entity(int(x)).name for x in body_entity]
        assert names == ["target", "camera"] * n, "unexpected rigid body layout"
        bodies = e.create_shared_buffer("task_bodies", 2 * n, "uint32")
        b = np.arange(2 * n, dtype=np.uint32).reshape(n, 2)
        bodies.write(np.ascontiguousarray(b[:, ::-1]).reshape(-1))  # camera, target
        cams = e.cameras
        layers = int((cams["group"] == 0).sum())
        envs = np.arange(n)
        if not (np.array_equal(cams["env"], envs) and np.array_equal(cams["group"], envs // layers)
                and np.array_equal(cams["layer"], envs % layers)):
            raise RuntimeError("TargetCenter: cameras are not laid out one per env, envs in layer order")
        # camera groups (maxImageArrayLayers envs each): (first env, envs)
        self._groups = [(g * layers, int((cams["group"] == g).sum())) for g in range(int(cams["group"].max()) + 1)]
        out = {"task_bodies": bodies, "body_positions": "rigid.positions",
               "target_positions": "control.body_target_positions",
               "target_rotations": "control.body_target_rotations",
               "task_state": e.create_shared_buffer("task_state", (n, 4), "float32"),
               "task_target": e.create_shared_buffer("task_target", (n, 4), "float32")}
        return out

    def task_constants(self, reset_all: bool) -> dict:
        s = self.image_size
        return {"envs": self.num_envs, "max_steps": self.max_episode_steps, "seed": self.seed,
                "reset_all": int(reset_all), "action_scale": self.action_scale,
                "tan_half_fov": math.tan(math.radians(self.fov_y / 2)), "success": self.success,
                "start_offset": self.start_offset, "area_x": 0.4, "area_y0": 0.0, "area_y1": 0.6, "target_z": CUBE,
                "words_per_env": s * s * 3 // 4, "first_env": 0, "group_envs": self.num_envs, "pixels": s * s,
                "defer_start": int(self.final_observation), "env_offset": self.env_offset}

    def _create_passes(self) -> dict:
        b = self.buffers
        bindings = {"actions": b.actions, "rewards": b.rewards, "terminated": b.terminated, "truncated": b.truncated,
                    "episode_length": b.episode_length, "finished_length": b.finished_length, **self._task_buffers()}
        source = self.hlsl.read_text()
        words = self.image_size ** 2 * 3 // 4

        def act(entry, reset_all=False):
            return self.engine.create_compute_pass(source, name=f"TargetCenter.{entry}", entry=entry,
                                                   threads=self.num_envs, bindings=bindings,
                                                   constants=self.task_constants(reset_all))

        passes = {"act": act("act"), "act_reset_all": act("act", reset_all=True), "start": act("start"),
                  "observe": [], "observe_final": []}
        for g, (first, count) in enumerate(self._groups):
            observe, final = self.observe_passes(
                source, "observe", count * words, {"rgb": f"camera{g}.rgb"},
                {**self.task_constants(False), "first_env": first, "group_envs": count}, name=f"TargetCenter.observe{g}")
            passes["observe"] += observe
            passes["observe_final"] += final
        return passes

    def record_step(self, reset_all: bool = False) -> None:
        e, p, r = self.engine, self.passes, self.randomizer
        e.execute_compute_pass(p["act_reset_all" if reset_all else "act"])
        if r is not None:  # draws for the episodes act ended (and due intervals), shown from their next start
            r.sample(reset_all)
        e.step_physics()
        if self.final_observation and not reset_all:  # the final image, then the finished envs' next start
            self._render()
            self.observe(final=True)
            e.execute_compute_pass(p["start"])
            e.step_physics()  # the kinematic bodies to the new starts (the others stay where they are)
        if r is not None:
            r.apply()
        self._render()
        self.observe()

    def _render(self):
        self.engine.step_visual_sensors()
        if self.randomizer is not None:
            self.randomizer.after_sensors()

    def episode_flags(self) -> tuple:
        return (self.buffers.terminated, self.buffers.truncated)

    def _set_seed(self, seed: int):
        for key in ("act", "act_reset_all", "start"):
            self.passes[key].set_constant("seed", seed)
        if self.randomizer is not None:
            self.randomizer.set_seed(seed)

    def centre_offset(self) -> torch.Tensor:
        """The target's current normalised distance from the image centre, per env."""
        return tensor_view(self.engine.buffer("task_state"), self.device)[:, 2]
