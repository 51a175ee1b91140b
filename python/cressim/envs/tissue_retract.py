"""TissueRetract: the dVRK PSM grasps the free edge of a tissue sheet and lifts it (../shared/TASKS.md), z up.

Workload. The paper's scene has arbitrary units: a sheet 0.96 x 0.08 x 0.96 (y up) on a grid of
spacing 0.08 (about 12 x 2 x 12 particles), volume compliance 2.6e-3, 4 substeps. Read as metres
it would dwarf the PSM (240 mm of insertion, 10 mm jaws), so here the scene is at the PSM's real
scale: every length x 0.1 (one paper unit = 0.1 m), so the sheet is 96 x 96 x 8 mm
on the same grid (13 x 13 x 2 particles, 8 mm apart, 338 per env; 12 x 12 x 1 cells of 6 tets),
and its material is elastic tissue in SI units instead of a compliance: Young's modulus 10 kPa,
Poisson ratio 0.45, density 1000 kg/m^3 (soft tissue; 74 g), velocity damping 2/s, particle
radius 2.5 mm (contacts). Its far edge (y = +48 mm, both layers) is fixed to a table (a static
box, top at z = 0) that the sheet rests on. 60 Hz frames, 4 substeps, 4 elastic iterations.

The arm: the PSM with the Large Needle Driver (robots/dvrk_psm/psm_lnd.urdf) as kinematic
bodies (cressim.robots.ArmBodies: each link with collision geometry is a body, posed by the
URDF's FK), its remote centre of motion 150 mm above the sheet's centre, the base frame
unrotated (the instrument points down at yaw = pitch = 0). It starts at q0 = (0, 0, 0.1085, 0,
0, 0) with the jaws open, the grasp point 40 mm above the table. The grasp point ("tool tip"
below) is between the jaws, 8 mm beyond the jaw pivot (near the ends of the 10 mm jaws), fixed in
the wrist_yaw link; the Grasp pass (cressim.passes.Grasp) attaches up to 4 tissue particles
within 6 mm of it while the grasp is closed.

Action (7), each in [-1, 1] (NaN counts as 0): joint-target deltas per step for yaw, pitch,
insertion, roll, wrist pitch, wrist yaw, scaled by 0.01 rad, 0.01 rad, 1 mm, 0.02, 0.02, 0.02 rad
(0.6 rad/s, 60 mm/s, 1.2 rad/s at full action: within the URDF's velocity limits; the tip moves
up to about 2 mm a step) and clamped to the URDF's joint limits; then the grasp: > 0 closes it
(the jaws shut, 0 rad), < 0 opens it (0.6 rad), 0 keeps it. A grasp that closes on nothing stays
empty until it opens again.

Observation (29, SI units, positions in the env's frame): 0-5 joint targets q (rad, m), 6-11
their velocities (rad/s, m/s), 12-14 the target point (the current position of the tissue
particle to grasp), 15-17 the tool tip, 18-23 the tip's orientation (the wrist_yaw link's x and
y axes, y along the jaws), 24-26 target - tip, 27 attached (1 while the grasp holds particles),
28 lift (below).

Reward: - |tip - target| / 0.1 m (distance in the paper's units) + 0.5 attached + 4 lift, where
lift = the target particle's rise above its rest height / 20 mm (the target lift, 0.2 paper
units), clamped to [0, 1], and 0 unless attached. Terminated on success (attached and lift 1)
or when the solver flags the env; truncated at 180 steps. The target is a top-layer particle of
the free edge (y = -48 mm), one of 13, drawn per episode from a hash of seed, env and episode.
Note: as in the paper, success ends the episode while holding the tissue just below the target
lift keeps paying about 4.5 a step, so `terminated` (not the return) tells how often it succeeds.

A step is one frame, all on the GPU: `apply_action` (the actions move the joint targets in the
shared buffer `arm_joints` and the grasp commands, and write the arm's FK input), the arm's FK pass
(cressim.robots.link_poses: every env's link bodies posed), the Grasp pass, physics, `evaluate`
(reward, ends, a finished env's arm, grasp and target reset, `env.reset_mask` set), the engine's
reset of those envs (tissue, arm bodies at their start pose, attachments freed), `observe`.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

import cressim
from cressim.passes.grasp import Grasp

from .vector_env import Space, VectorEnv, checked_number, tensor_view

SHEET_HALF = (0.048, 0.048, 0.004)  # m
CELLS = (12, 12, 1)  # 8 mm spacing: 13 x 13 x 2 particles
PARTICLE_RADIUS = 0.0025  # m
TABLE_HALF = (0.1, 0.1, 0.01)  # m, top at z = 0
RCM = (0.0, 0.0, 0.15)  # m: the arm's remote centre of motion, above the sheet's centre
JOINTS = ("yaw", "pitch", "insertion", "roll", "wrist_pitch", "wrist_yaw")  # the dVRK's order, as ArmBodies
START_Q = (0.0, 0.0, 0.1085, 0.0, 0.0, 0.0)
ACTION_SCALE = (0.01, 0.01, 0.001, 0.02, 0.02, 0.02)  # rad or m per step per unit action
JAW_OPEN, JAW_CLOSED = 0.6, 0.0  # rad
TIP_BODY = "PSM1_wrist_yaw_link"  # the jaws' pivot; its y axis points along the jaws
GRASP_POINT = (0.0, 0.008, 0.0)  # m, in TIP_BODY's frame
LENGTH_SCALE = 0.1  # m: one unit of the paper's scene
FRAME = 1 / 60


class TissueRetract(VectorEnv):
    hlsl = Path(__file__).with_name("tissue_retract.hlsl")
    entries = ("apply_action", "evaluate", "observe")
    observation_space = Space((29,))
    action_space = Space((7,), -1.0, 1.0)
    max_episode_steps = 180

    def __init__(self, num_envs: int, *, youngs_modulus: float = 1e4, poisson_ratio: float = 0.45,
                 density: float = 1000.0, target_lift: float = 0.02, grasp_reach: float = 0.006, **kwargs):
        """Tissue material (Pa, -, kg/m^3), the lift that counts as success (m) and the grasp's
        reach (m); other keywords go to VectorEnv."""
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise ValueError(f"TissueRetract: num_envs must be a positive integer, got {num_envs!r}")
        self.youngs_modulus = checked_number("TissueRetract", "youngs_modulus", youngs_modulus)
        self.poisson_ratio = checked_number("TissueRetract", "poisson_ratio", poisson_ratio, 0.0, 0.5)
        self.density = checked_number("TissueRetract", "density", density)
        self.target_lift = checked_number("TissueRetract", "target_lift", target_lift)
        self.grasp_reach = checked_number("TissueRetract", "grasp_reach", grasp_reach)
        super().__init__(num_envs, **kwargs)
        self.joints = tensor_view(self.buffers.extra["arm_joints"], self.device)  # (N, 12): q, dq/dt
        self.grasp_commands = tensor_view(self.grasp.commands, self.device)  # (N, 4) int32, x: closed

    # --- the scene ---------------------------------------------------------------------------
    def build_world(self, num_envs: int) -> cressim.World:
        from cressim.robots import ArmBodies, robot_dir  # on first use: the URDF stack takes a second to import

        world = cressim.World(cressim.SceneLayout(num_envs))
        self.arm = ArmBodies(
            robot_dir() / "psm_lnd.urdf", num_envs, base_position=RCM, base_rotation=(0.0, 0.0, 0.0, 1.0),
            publish_rate=1 / FRAME, physics_rate=4 / FRAME, initial_q=np.array(START_Q), initial_jaw=JAW_OPEN,
            dof=6, world=world)
        mesh = cressim.TetMesh.box(SHEET_HALF, CELLS)
        rest = np.asarray(mesh.positions)
        fixed = np.nonzero(rest[:, 1] > SHEET_HALF[1] - 1e-6)[0]  # the far edge
        top_edge = (rest[:, 1] < -SHEET_HALF[1] + 1e-6) & (rest[:, 2] > SHEET_HALF[2] - 1e-6)
        self.target_particles = np.nonzero(top_edge)[0].astype(np.uint32)  # local indices, env-relative
        self.particles_per_env = len(rest)
        for env in range(num_envs):
            table = world.create_entity(env=env, name="table")
            table.add(cressim.Transform(position=(0.0, 0.0, -TABLE_HALF[2])))
            table.add(cressim.Collider(cressim.Shape.box(TABLE_HALF)))
            sheet = world.create_entity(env=env, name="tissue")
            sheet.add(cressim.Transform(position=(0.0, 0.0, SHEET_HALF[2] + PARTICLE_RADIUS)))
            sheet.add(cressim.SoftBody(mesh, fixed=fixed, youngs_modulus=self.youngs_modulus,
                                       poisson_ratio=self.poisson_ratio, density=self.density,
                                       radius=PARTICLE_RADIUS, damping=2.0))
        return world

    def physics_settings(self) -> cressim.PhysicsSettings:
        return cressim.PhysicsSettings(dt=FRAME, substeps=4, particle_iterations=4, max_particle_attachments_per_env=4)

    # --- buffers and passes -------------------------------------------------------------------
    def _create_passes(self) -> dict:
        e, n = self.engine, self.num_envs
        self.arm.bind(e)
        tip = self.arm.body_names.index(TIP_BODY)
        self.grasp = Grasp(e, self.arm.body_entity_ids[:, tip], GRASP_POINT, self.grasp_reach)
        tip_rows = self.arm.body_rows[:, tip].cpu().numpy().astype(np.uint32)
        limits = {j.name: j.limit for j in self.arm.urdf.robot.joints}
        extra = {"arm_joints": e.create_shared_buffer("arm_joints", (n, 12), "float32"),
                 "arm_start": e.create_shared_buffer("arm_start", 6, "float32"),
                 "arm_limits": e.create_shared_buffer("arm_limits", (3, 6), "float32"),
                 "tip_bodies": e.create_shared_buffer("tip_bodies", n, "uint32"),
                 "target_candidates": e.create_shared_buffer("target_candidates", len(self.target_particles),
                                                             "uint32"),
                 "task_state": e.create_shared_buffer("task_state", (n, 4), "uint32")}
        extra["arm_start"].write(np.asarray(START_Q, np.float32))
        extra["arm_limits"].write(np.array([[limits[j].lower for j in JOINTS], [limits[j].upper for j in JOINTS],
                                            ACTION_SCALE], np.float32))
        extra["tip_bodies"].write(tip_rows)
        extra["target_candidates"].write(self.target_particles)
        self.buffers.extra = extra
        return super()._create_passes()

    def task_bindings(self) -> dict:
        return {**self.buffers.extra, "grasps": self.grasp.commands, "grasp_points": self.grasp.points,
                "arm_joint_values": self.arm.link_poses.joint_values,
                "particle_positions": "particles.positions", "initial_positions": "particles.initial_positions",
                "particle_env_ranges": "particles.env_ranges", "body_positions": "rigid.positions",
                "body_rotations": "rigid.rotations"}

    def task_constants(self, reset_all: bool) -> dict:
        return {"envs": self.num_envs, "max_steps": self.max_episode_steps, "reset_all": int(reset_all),
                "seed": self.seed, "candidates": len(self.target_particles), "target_lift": self.target_lift,
                "length_scale": LENGTH_SCALE, "frame": FRAME, "jaw_open": JAW_OPEN, "jaw_closed": JAW_CLOSED}

    # --- a step ---------------------------------------------------------------------------------
    def act(self):
        """The task's `apply_action`, the arm's FK pass, then the grasp pass."""
        self.engine.execute_compute_pass(self.passes["apply_action"])
        self.arm.pose()
        self.grasp.execute()
