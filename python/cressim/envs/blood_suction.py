"""BloodSuction: the dVRK PSM's suction tool clears a pool of blood from a soft basin
(../shared/TASKS.md), z up, SI units.

Workload. The paper's scene has arbitrary units: about 605 fluid particles (11 x 5 x 11) in a
soft tet-mesh container; suction pulls particles within 1.0 unit toward the tip and removes
those within 0.25. Here the scene is at the PSM's real scale, one paper unit = 20 mm: the
removal radius 0.25 units is 5 mm, about the nozzle's outer diameter (the twin's psm_suction
radius, scenes/psm_suction.yaml). The blood is 605 particles (an 11 x 11 block, 5 layers)
3 mm apart, radius 1.5 mm, 1060 kg/m^3 (whole blood), XSPH viscosity 0.05, cohesion 0.02, the
radius scenes/blood_suction.yaml chose so that blood does not seep between the basin's
particles. The container is that scene's basin made deeper: elastic tissue 60 x 60 x 24 mm
(6 mm tet cubes, 10 x 10 x 4, 458 particles of radius 4 mm, overlapping so the blood cannot slip
between them) with a pocket 48 x 48 x 18 mm open at the top; Young's modulus 15 kPa, Poisson
ratio 0.45, 1000 kg/m^3, velocity damping 2/s; its bottom layer is held to a table (a static
box, top at z = 0). The block starts 5.5 mm clear of the pocket's floor (a blood and a tissue
radius) and settles within about 20 frames into a pool about 6 mm deep (particle centres 12.5 to
19 mm above the table); the 18 mm pocket (the scene file's is 12 mm) keeps the rim (its
particles' centres at 28 mm) well above it when the tool displaces blood. The pull: while the
valve is open the blood within 20 mm (1.0 unit, 4 removal radii) flows toward the tube's end as
into a point sink at a wall of 1 L/min (`flow_rate`, cressim.passes.Suction): 0.11 m/s at the
mouth and 6.6 mm/s at 20 mm. 60 Hz frames, 4 substeps, 4 particle
iterations.

The arm: the PSM with our suction/irrigator (robots/dvrk_psm/psm_suction.urdf: yaw, pitch,
insertion, roll, a straight nozzle) as kinematic bodies (cressim.robots.ArmBodies in this task's
world), its remote centre of motion 150 mm above the table over the pool's centre, the tool
pointing down at yaw = pitch = 0. It starts at q0 = (0, 0, 0.115 m, 0): the tip (the nozzle's
open end, 9.1 mm along the suction tube link's z) 41.5 mm above the table, about 22 mm above the
settled blood (out of reach). The shaft and nozzle are drawn (URDF visuals); the rest of the
arm is out of view.

Action (5), each in [-1, 1] (NaN counts as 0): joint-target deltas per step for yaw, pitch,
insertion, roll, scaled by 0.01 rad, 0.01 rad, 1 mm, 0.02 rad (the tip moves up to about 2 mm a
step), clamped to task limits inside the URDF's: yaw and pitch +-0.35 rad (the tip stays over
the basin), insertion 0.08 .. 0.1395 m (the tip stops 3 mm above the pocket floor's particle
spheres: squeezing the held floor between a kinematic tool and the table only strains the
solver); roll turns the round nozzle about its axis (kept for the dVRK's joint set). Then the
valve: the suction is on unless action 4 < 0. So zero actions (the benchmark's) suck, as the
paper's always-on suction; a policy may close the valve, which costs nothing and earns nothing.

Observation: 13 numbers, then the camera's 64 x 64 RGB image, one float32 row per env
(13 + 64 * 64 * 3): 0-3 joint targets (yaw, pitch, insertion, roll; rad, m), 4-6 the tip
(env frame, m), 7-9 the nearest active blood particle - tip (m; 0 when none is left), 10 the
fraction of the blood removed, 11 the valve (1 open), 12 the episode's elapsed share (steps /
240); then the image (rows, columns, RGB) in [0, 1]. `split_observation` gives both parts. The
camera looks at the basin from 65 mm in front and 95 mm above the table's centre (45 deg fov).

Reward: 0.03 per particle removed this step + progress toward the nearest active particle: how
much nearer the tip came to where that particle was at the last observation, / one paper unit
(20 mm). Measured against that fixed point, blood that flows or is sucked away neither pays nor
costs (a plain nearest distance jumps up when the nearest particle is removed, punishing the
removal, and moves as the pool settles); a still tip earns no progress. Terminated when
the field is clear (`clear_fraction`, 95 % of the blood removed: success; the paper gives no
success, only the 240-step truncation) or the solver flags the env; truncated at 240 steps.
Success ends the episode before the last 5 % of the blood pays; `absorbing_success=True` also pays
the removal reward of the blood left when the field clears (as if it were removed), so that
clearing is never worth less than lingering over the last drops; `success_reward` adds a bonus on
the step the field clears (as TargetCenter's +1; 0 by default), so that clearing in time is worth
more than nearly clearing. The paper's reward is the default.

Each episode starts with the same block of blood and the arm at q0 but for its yaw and pitch,
drawn uniformly within +-`start_spread` (0.1 rad: the tip up to 11 mm off the pool's centre,
still out of reach above it) from a hash of the seed, the env and its episode count, so that
episodes differ and a trained policy is evaluated over many starts (`start_spread=0`: every
episode alike). A finished env's arm, blood and counters are reset on the GPU (`evaluate`) by the
engine's per-env reset.

A step is one frame, all on the GPU: `apply_action` (the actions move the joint targets in the
shared buffer `arm_joints` and the valve, the Suction's `commands`), the arm's FK pass
(cressim.robots.link_poses), the Suction pass (removes blood within reach, counted per env),
physics, `evaluate`, the engine's reset of flagged envs, rendering, `observe` (numbers) and one
`observe_image` pass per camera group.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import torch

import cressim
from cressim.passes.suction import FLOW_RATE, Suction
from cressim.robots.dvrk import PSM_JOINTS
from cressim.tet_mesh_file import boundary_triangles

from .vector_env import VectorEnv, box, checked_number, tensor_view

# success: the field is clear when 95 % of the blood is gone. Scripted tips (the greedy chase of
# the nearest particle and a raster sweep, docs/envs.md) leave 9 to 12 of the 605 particles after
# the 240 steps: the last blood trickles out of the pocket's corners, where the shaft's reach
# keeps the tip 6 mm above it.
CLEAR_FRACTION = 0.95
CELL = 0.006  # m: the basin's tet cubes
BASIN_HALF = (0.03, 0.03, 0.012)  # m
POCKET_HALF = (0.024, 0.024)  # m; the pocket's floor is one cell above the basin's bottom
TISSUE_RADIUS = 0.004  # m
BLOOD_RADIUS = 0.0015  # m
BLOCK = (11, 11, 5)  # blood particles along x, y, z: 605
TABLE_HALF = (0.15, 0.15, 0.01)  # m, top at z = 0; the camera sees no edge
RCM = (0.0, 0.0, 0.15)  # m
JOINTS = PSM_JOINTS[:4]  # a wrist-less tool
START_Q = (0.0, 0.0, 0.115, 0.0)
ACTION_SCALE = (0.01, 0.01, 0.001, 0.02)  # rad or m per step per unit action
TASK_LIMITS = {"yaw": (-0.35, 0.35), "pitch": (-0.35, 0.35), "insertion": (0.08, 0.1395)}
YAW_PITCH_LIMIT = TASK_LIMITS["yaw"][1]
START_SPREAD = 0.1  # rad: the start yaw and pitch are drawn within this of START_Q's
TUBE = "PSM1_suction_tube_link"
TIP = (0.0, 0.0, 0.0091)  # m, in TUBE's frame: the nozzle's open end
SHOWN_LINKS = ("PSM1_shaft_link", TUBE)  # the links the camera sees
EYE, LOOK_AT = (0.0, -0.065, 0.095), (0.0, 0.0, 0.012)
LENGTH_SCALE = 0.02  # m: one unit of the paper's scene
FRAME = 1 / 60
NUMBERS = 13  # observation values before the image


def basin_mesh() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The basin's particles (bottom at z = 0), tets and surface triangles: a box of tet cubes
    without the pocket's."""
    box = cressim.TetMesh.box(BASIN_HALF, tuple(round(2 * h / CELL) for h in BASIN_HALF))
    points = np.asarray(box.positions, np.float64) + [0.0, 0.0, BASIN_HALF[2]]
    tets = np.asarray(box.tets)
    centre = points[tets].mean(axis=1)
    pocket = (np.abs(centre[:, 0]) < POCKET_HALF[0]) & (np.abs(centre[:, 1]) < POCKET_HALF[1]) & (centre[:, 2] > CELL)
    tets = tets[~pocket]
    used = np.unique(tets)
    index = np.full(len(points), -1)
    index[used] = np.arange(len(used))
    points, tets = points[used], index[tets]
    return points.astype(np.float32), tets.astype(np.int32), boundary_triangles(points, tets)


def blood_block() -> np.ndarray:
    """The blood's start (basin frame): the block centred over the pocket floor, 5.5 mm above
    the floor's particle centres."""
    z, y, x = np.meshgrid(*(np.arange(n) for n in BLOCK[::-1]), indexing="ij")
    grid = np.stack([x, y, z], -1).reshape(-1, 3) * 2 * BLOOD_RADIUS
    origin = [-(BLOCK[0] - 1) * BLOOD_RADIUS, -(BLOCK[1] - 1) * BLOOD_RADIUS, CELL + TISSUE_RADIUS + BLOOD_RADIUS]
    return (grid + origin).astype(np.float32)


def _look_at(eye, target) -> tuple:
    """xyzw rotation turning a camera's +z (view) toward target, its +y (image down) downward."""
    forward = np.subtract(target, eye) / np.linalg.norm(np.subtract(target, eye))
    right = np.cross(forward, (0.0, 0.0, 1.0))
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    from cressim.robots.kinematics import rotation_xyzw

    return rotation_xyzw(np.stack([right, down, forward], axis=1))


class BloodSuction(VectorEnv):
    hlsl = Path(__file__).with_name("blood_suction.hlsl")
    entries = ("apply_action", "evaluate", "observe")  # images: observe_image
    single_action_space = box((5,), -1.0, 1.0)
    own_cameras = True  # render() shows the task's camera
    renders_cameras = True
    max_episode_steps = 240
    removal_reward = 0.03

    def __init__(self, num_envs: int, *, image_size: int = 64, suction_radius: float = 0.005,
                 flow_rate: float = FLOW_RATE, youngs_modulus: float = 15e3, poisson_ratio: float = 0.45,
                 density: float = 1000.0, clear_fraction: float = CLEAR_FRACTION, absorbing_success: bool = False,
                 start_spread: float = START_SPREAD, success_reward: float = 0.0, **kwargs):
        """The camera image's side (pixels), the suction's removal radius (m; it draws the blood
        within 4 radii in) and flow rate (m^3/s), the basin's material (Pa, -, kg/m^3) and the share
        of the blood whose removal clears the field (success, the episode ends); `absorbing_success`
        `start_spread` (rad) and `success_reward` (module docstring); other keywords go to VectorEnv."""
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise ValueError(f"BloodSuction: num_envs must be a positive integer, got {num_envs!r}")
        # at least 32: the CNN's three strided convolutions leave a 2 x 2 map of it
        if isinstance(image_size, bool) or not isinstance(image_size, (int, np.integer)) or not 32 <= image_size <= 512:
            raise ValueError(f"BloodSuction: image_size must be an integer in [32, 512], got {image_size!r}")
        self.image_size = int(image_size)
        self.suction_radius = checked_number("BloodSuction", "suction_radius", suction_radius, 0.0, 0.05)
        self.flow_rate = checked_number("BloodSuction", "flow_rate", flow_rate, 0.0, 1e-3)
        self.youngs_modulus = checked_number("BloodSuction", "youngs_modulus", youngs_modulus)
        self.poisson_ratio = checked_number("BloodSuction", "poisson_ratio", poisson_ratio, 0.0, 0.5)
        self.density = checked_number("BloodSuction", "density", density)
        self.clear_fraction = checked_number("BloodSuction", "clear_fraction", clear_fraction, 0.0, 1.0, with_high=True)
        if not isinstance(absorbing_success, bool):
            raise ValueError(f"BloodSuction: absorbing_success must be True or False, got {absorbing_success!r}")
        self.absorbing_success = absorbing_success
        self.success_reward = checked_number("BloodSuction", "success_reward", success_reward, 0.0, 1e3, with_low=True)
        self.start_spread = checked_number("BloodSuction", "start_spread", start_spread, 0.0, YAW_PITCH_LIMIT,
                                           with_low=True)
        self.single_observation_space = box((NUMBERS + 3 * self.image_size ** 2,))
        super().__init__(num_envs, **kwargs)
        self.joints = tensor_view(self.buffers.extra["arm_joints"], self.device)  # (N, 4)
        self.suction_commands = tensor_view(self.suction.commands, self.device)  # (N, 4) int32: x on, w removed

    # --- the scene ---------------------------------------------------------------------------
    def build_world(self, num_envs: int) -> cressim.World:
        from cressim.robots import ArmBodies, robot_dir  # on first use: the URDF stack takes a second to import

        s = self.image_size
        world = cressim.World(cressim.SceneLayout(num_envs, max_renderables_per_env=3 + len(SHOWN_LINKS),
                                                  max_lights_per_env=1, max_cameras_per_env=1))
        self.arm = ArmBodies(
            robot_dir() / "psm_suction.urdf", num_envs, base_position=RCM, base_rotation=(0.0, 0.0, 0.0, 1.0),
            publish_rate=1 / FRAME, physics_rate=4 / FRAME, initial_q=np.array(START_Q), initial_jaw=0.0, dof=4,
            world=world)
        self.arm.show(world, range(num_envs), SHOWN_LINKS)
        points, tets, triangles = basin_mesh()
        held = np.nonzero(points[:, 2] < 1e-6)[0]  # the bottom layer, on the table
        block = blood_block()
        self.fluid_count = len(block)
        self.clear_count = max(1, math.ceil(self.clear_fraction * self.fluid_count - 1e-9))
        self.particles_per_env = len(points) + len(block)
        table_mesh = world.add_mesh(cressim.Mesh.box(TABLE_HALF))
        on_table = (0.0, 0.0, TISSUE_RADIUS)  # the bottom particles' spheres rest on the table
        for env in range(num_envs):
            table = world.create_entity(env=env, name="table")
            table.add(cressim.Transform(position=(0.0, 0.0, -TABLE_HALF[2])))
            table.add(cressim.Collider(cressim.Shape.box(TABLE_HALF)))
            table.add(cressim.Renderable(table_mesh, color=(0.35, 0.42, 0.35, 1.0), roughness=0.8))
            basin = world.create_entity(env=env, name="basin")
            basin.add(cressim.Transform(position=on_table))
            basin.add(cressim.SoftBody(points, tets, triangles, fixed=held, youngs_modulus=self.youngs_modulus,
                                       poisson_ratio=self.poisson_ratio, density=self.density,
                                       radius=TISSUE_RADIUS, damping=2.0, friction=0.5))
            basin.add(cressim.Material(color=(0.78, 0.42, 0.38, 1.0), roughness=0.45))
            blood = world.create_entity(env=env, name="blood")
            blood.add(cressim.Transform(position=on_table))
            blood.add(cressim.Fluid(block, radius=BLOOD_RADIUS, rest_density=1060, viscosity=0.05, cohesion=0.02))
            blood.add(cressim.Material(color=(0.05, 0.001, 0.001, 1.0), roughness=0.15))
            light = world.create_entity(env=env, name="light")
            light.add(cressim.Transform(rotation=_look_at((0.2, -0.3, 1.0), (0.0, 0.0, 0.0))))
            light.add(cressim.Light(intensity=1.0, ambient=0.3))
            camera = world.create_entity(env=env, name="camera")
            camera.add(cressim.Transform(position=EYE, rotation=_look_at(EYE, LOOK_AT)))
            camera.add(cressim.Camera(width=s, height=s, fov_y=45.0, near=0.01, far=1.0, products=["rgb"]))
        return world

    def physics_settings(self) -> cressim.PhysicsSettings:
        return cressim.PhysicsSettings(dt=FRAME, substeps=4, particle_iterations=4, max_particle_attachments_per_env=0)

    # --- buffers and passes -------------------------------------------------------------------
    def _create_passes(self) -> dict:
        e, n = self.engine, self.num_envs
        self.arm.bind(e)
        mapping = e.particle_mapping
        fluid = mapping["object_kind"] == mapping["kinds"]["fluid"]
        offsets = mapping["object_offset"][fluid] - mapping["env_offset"][mapping["object_env"][fluid]]
        if not (np.all(offsets == offsets[0]) and np.all(mapping["object_count"][fluid] == self.fluid_count)):
            raise RuntimeError("BloodSuction: the blood is not at the same place in every env's particles")
        self.fluid_offset = int(offsets[0])  # env-relative index of the first blood particle
        tubes, tip = self.arm.link_point(TUBE, TIP)
        self.suction = Suction(e, tubes, tip, self.suction_radius, flow_rate=self.flow_rate)
        tube_rows = self.arm.body_rows[:, self.arm.body_names.index(TUBE)].cpu().numpy().astype(np.uint32)
        extra = {"arm_joints": e.create_shared_buffer("arm_joints", (n, len(JOINTS)), "float32"),
                 "arm_start": e.create_shared_buffer("arm_start", len(JOINTS), "float32"),
                 "arm_limits": e.create_shared_buffer("arm_limits", (3, len(JOINTS)), "float32"),
                 "tip_bodies": e.create_shared_buffer("tip_bodies", n, "uint32"),
                 "task_aim": e.create_shared_buffer("task_aim", (n, 2, 4), "float32"),
                 "task_state": e.create_shared_buffer("task_state", (n, 2), "uint32")}
        extra["arm_start"].write(np.asarray(START_Q, np.float32))
        limits = {j.name: j.limit for j in self.arm.urdf.robot.joints}
        bounds = [TASK_LIMITS.get(n, (limits[n].lower, limits[n].upper)) for n in JOINTS]
        extra["arm_limits"].write(np.array([[lo for lo, _ in bounds], [hi for _, hi in bounds], ACTION_SCALE],
                                           np.float32))
        extra["tip_bodies"].write(tube_rows)
        self.buffers.extra = extra
        self._camera_groups = self._check_cameras()
        passes = super()._create_passes()
        source = self.hlsl.read_text()
        for g, (first, count) in enumerate(self._camera_groups):  # the images beside the numbers
            image, final_image = self.observe_passes(
                source, "observe_image", count * 3 * self.image_size ** 2, {"rgb": f"camera{g}.rgb"},
                {**self.task_constants(False), "first_env": first, "group_envs": count})
            passes["observe"] += image
            passes["observe_final"] += final_image
        return passes

    def _check_cameras(self) -> list:
        """Camera groups (an image array of up to maxImageArrayLayers envs each) as (first env,
        envs), after checking that env k's camera is layer k of its group."""
        cams, n = self.engine.cameras, self.num_envs
        layers = int((cams["group"] == 0).sum())
        envs = np.arange(n)
        if not (np.array_equal(cams["env"], envs) and np.array_equal(cams["group"], envs // layers)
                and np.array_equal(cams["layer"], envs % layers)):
            raise RuntimeError("BloodSuction: cameras are not laid out one per env, envs in layer order")
        return [(g * layers, int((cams["group"] == g).sum())) for g in range(int(cams["group"].max()) + 1)]

    def task_bindings(self) -> dict:
        return {**self.buffers.extra, "suctions": self.suction.commands, "suction_tips": self.suction.tips,
                "arm_joint_values": self.arm.link_poses.joint_values,
                "particle_positions": "particles.positions", "particle_phases": "particles.phases",
                "particle_env_ranges": "particles.env_ranges",
                "body_positions": "control.body_target_positions", "body_rotations": "control.body_target_rotations"}

    def task_constants(self, reset_all: bool) -> dict:
        return {"envs": self.num_envs, "max_steps": self.max_episode_steps, "reset_all": int(reset_all),
                "fluid_offset": self.fluid_offset, "fluid_count": self.fluid_count, "clear_count": self.clear_count,
                "absorbing_success": int(self.absorbing_success), "success_reward": self.success_reward,
                "seed": self.seed,
                "start_spread": self.start_spread,
                "removal_reward": self.removal_reward, "length_scale": LENGTH_SCALE,
                "row": self.single_observation_space.shape[0], "first_env": 0, "group_envs": self.num_envs,
                "pixels": self.image_size ** 2}

    # --- a step ---------------------------------------------------------------------------------
    def act(self):
        """The task's `apply_action`, the arm's FK pass, then the suction pass."""
        self.engine.execute_compute_pass(self.passes["apply_action"])
        self.arm.pose()
        self.suction.execute()

    def sense(self):
        """The arm posed at its joint targets (a reset env's drawn start; idempotent otherwise) and
        the cameras (`observe_image` copies their images beside the numbers `observe` writes)."""
        self.arm.pose()
        self.engine.step_visual_sensors()

    def split_observation(self, obs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """(numbers (N, 13), image (N, H, W, 3)) views of observations (N, 13 + H W 3)."""
        s = self.image_size
        return obs[:, :NUMBERS], obs[:, NUMBERS:].reshape(-1, s, s, 3)

    def removed(self) -> torch.Tensor:
        """Blood particles each env's suction has removed this episode."""
        return self.suction_commands[:, 3]
