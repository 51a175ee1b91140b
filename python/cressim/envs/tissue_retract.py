"""TissueRetract: the dVRK PSM grasps the free edge of a tissue flap and lifts it (../shared/TASKS.md), z up.

Scene: the twin's (scenes/psm_retraction.yaml), so that a policy trained here meets the same
world in the twin (examples/sim_to_real.py): its engine scene (scenes/tissue_retraction.yaml:
a table, top at z = 0.15 m, and a 60 x 40 x 6 mm flap of 10 kPa tissue, Poisson ratio 0.45,
1000 kg/m^3, on 13 x 9 x 3 particles (351, 1,152 tets), its far edge (+y) held to the table),
without its camera, light and suture thread; the arm's base (its remote centre of motion, 150 mm
above the table at the flap's centre), its robot (the PSM with the Large Needle Driver,
robots/dvrk_psm/psm_lnd.urdf) and the grasp's reach. The paper's workload is a sheet of about
12 x 2 x 12 particles (338), volume compliance 2.6e-3, 4 substeps, in arbitrary units: this flap
has about as many particles, in SI units at the PSM's real scale. Physics: 60 Hz frames, 4
substeps, 2 elastic iterations (the flap lifted 15 mm by its edge: the held force and the lifted
shape at 2 iterations are within 1.5 % and 0.03 mm of those at 4; 1 iteration within 3 %), the
particle passes outside the elastic solve (attachments, the gather) once a substep (contacts
with the table and the arm are inside the elastic solve: the same force and shape as every
iteration), up to 4 held particles per env.

The arm: every link with collision geometry is a kinematic body (cressim.robots.ArmBodies, posed
by the URDF's FK on the GPU). It starts at the twin's home joints q0 = (0, 0, 0.1, 0, 0, 0) with
the jaws open, the grasp point 43 mm above the flap. The grasp point ("tool tip" below) is
cressim.robots.JAW_GRASP_POINT, between the jaws, fixed in the wrist_yaw link; the Grasp pass
(cressim.passes.Grasp) attaches up to 4 tissue particles within the grasp's reach of it while
the grasp is closed, as the twin's jaws do.

Action (7), each in [-1, 1] (NaN counts as 0): joint-target deltas per step for yaw, pitch,
insertion, roll, wrist pitch, wrist yaw, scaled by 0.01 rad, 0.01 rad, 1 mm, 0.02, 0.02, 0.02 rad
(0.6 rad/s, 60 mm/s, 1.2 rad/s at full action: within the URDF's velocity limits; the tip moves
up to about 2 mm a step) and clamped to the URDF's joint limits; then the grasp: > 0 closes it
(the jaws shut, 0 rad), < 0 opens it (0.6 rad), 0 keeps it. A grasp that closes on nothing stays
empty until it opens again.

Observation (29, SI units, positions in the env's frame): 0-5 joint targets q (rad, m), 6-11
their velocities (rad/s, m/s), 12-14 the target point, 15-17 the tool tip, 18-23 the tip's
orientation (the wrist_yaw link's x and y axes, y along the jaws), 24-26 target - tip, 27 the
grasp, 28 lift. Two kinds (`observation`):
- "state" (the paper's): the target point is the current position of the tissue particle to
  grasp, 27 is 1 while the grasp holds particles, lift is the particle's rise (below);
- "crtk": only what a dVRK client knows from CRTK topics and its own commands, so that the same
  policy runs against the twin or a real arm: the target is the particle's rest position (given
  to the client, as a camera would), 27 is 1 while the grasp is commanded closed, and lift is the
  tool tip's rise since the grasp closed, / the target lift, clamped to [0, 1] (0 while open).

Reward (both kinds): - |tip - target| / 0.1 m (distance in the paper's units) + 0.5 attached + 4
lift, where lift = the target particle's rise above its rest height / 20 mm (the target lift,
0.2 paper units), clamped to [0, 1], and 0 unless attached. Terminated on success (attached and
lift 1) or when the solver flags the env; truncated at 180 steps. The target is a top-layer
particle of the flap's free edge (y = -20 mm), one of 13, drawn per episode from a hash of seed,
env and episode. Note: as in the paper, success ends the episode while holding the tissue just
below the target lift keeps paying about 4.5 a step, so `terminated` (not the return) tells how
often it succeeds, and a policy that maximises the paper's return learns to hover just below the
target lift. `absorbing_success=True` makes success pay its step's reward once more for every
step left before the time limit (as if the task stayed in its success state), so that finishing
is never worth less than hovering; the paper's reward is the default.

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
from cressim.twin_scene_file import load_scene
from cressim.robots.dvrk import PSM_JOINTS

from .vector_env import box, VectorEnv, checked_number, tensor_view

SCENE = "psm_retraction.yaml"  # the twin's scene: its world, the arm's base and the grasp
FLAP = "flap"  # the scene's entity whose free edge is grasped
SKIPPED = ("camera", "light", "strand")  # what the task leaves out of the world (sensors, the thread)
JOINTS = PSM_JOINTS  # the dVRK's order, as ArmBodies
ACTION_SCALE = (0.01, 0.01, 0.001, 0.02, 0.02, 0.02)  # rad or m per step per unit action
JAW_OPEN, JAW_CLOSED = 0.6, 0.0  # rad
LENGTH_SCALE = 0.1  # m: one unit of the paper's scene
FRAME = 1 / 60
OBSERVATIONS = ("state", "crtk")


class TissueRetract(VectorEnv):
    hlsl = Path(__file__).with_name("tissue_retract.hlsl")
    entries = ("apply_action", "evaluate", "observe")
    single_observation_space = box((29,))
    single_action_space = box((7,), -1.0, 1.0)
    max_episode_steps = 180
    video_view = ((0.07, -0.1, 0.23), (0.0, -0.005, 0.16))  # the twin's camera

    def __init__(self, num_envs: int, *, scene: str = SCENE, observation: str = "state", target_lift: float = 0.02,
                 grasp_reach: float | None = None, absorbing_success: bool = False, **kwargs):
        """`scene`: a twin scene file (its world, arm base and grasp reach); `observation`: "state"
        or "crtk"; the lift that counts as success (m) and the grasp's reach (m, default the
        scene's); `absorbing_success` (module docstring); other keywords go to VectorEnv."""
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise ValueError(f"TissueRetract: num_envs must be a positive integer, got {num_envs!r}")
        if observation not in OBSERVATIONS:
            raise ValueError(f"TissueRetract: observation must be one of {', '.join(OBSERVATIONS)}, got {observation!r}")
        self.scene = load_scene(scene)
        if self.scene.robot != "psm_lnd" or not self.scene.world:
            raise ValueError(f"TissueRetract: {self.scene.path} must give a world and the needle driver (psm_lnd)")
        if not isinstance(absorbing_success, bool):
            raise ValueError(f"TissueRetract: absorbing_success must be True or False, got {absorbing_success!r}")
        self.observation, self.absorbing_success = observation, absorbing_success
        self.target_lift = checked_number("TissueRetract", "target_lift", target_lift)
        self.grasp_reach = checked_number("TissueRetract", "grasp_reach",
                                          self.scene.grasp_reach if grasp_reach is None else grasp_reach)
        self.start_q = tuple(float(v) for v in (self.scene.home_jp or self.scene.initial_jp))
        super().__init__(num_envs, **kwargs)
        self.joints = tensor_view(self.buffers.extra["arm_joints"], self.device)  # (N, 12): q, dq/dt
        self.grasp_commands = tensor_view(self.grasp.commands, self.device)  # (N, 4) int32, x: closed

    # --- the scene ---------------------------------------------------------------------------
    def build_world(self, num_envs: int) -> cressim.World:
        from cressim.robots import ArmBodies, robot_dir  # on first use: the URDF stack takes a second to import
        from cressim.scene_file import add_scene

        scene = self.scene
        # the table and the flap; rendered envs also draw the arm's links
        world = cressim.World(cressim.SceneLayout(num_envs, max_renderables_per_env=2 if self.render_mode is None else 16))
        self.arm = ArmBodies(
            robot_dir() / f"{scene.robot}.urdf", num_envs, base_position=scene.base_position,
            base_rotation=scene.base_rotation, publish_rate=1 / FRAME, physics_rate=4 / FRAME,
            initial_q=np.array(self.start_q), initial_jaw=JAW_OPEN, dof=6, world=world)
        if self.render_mode is not None:
            self.arm.show(world, self.render_envs)
        added = add_scene(world, scene.world, skip=SKIPPED)
        if FLAP not in added.labels.values():
            raise ValueError(f"TissueRetract: {scene.world} has no entity '{FLAP}' to grasp")
        self.scene_randomization = added.randomization
        self._world = world
        return world

    def physics_settings(self) -> cressim.PhysicsSettings:
        return cressim.PhysicsSettings(dt=FRAME, substeps=4, particle_iterations=2, particle_contact_iterations=1,
                                       max_particle_attachments_per_env=4)

    # --- buffers and passes -------------------------------------------------------------------
    def _create_passes(self) -> dict:
        e, n = self.engine, self.num_envs
        self.arm.bind(e)
        self._find_targets()
        from cressim.robots import JAW_GRASP_POINT, JAW_LINK

        tip = self.arm.body_names.index(JAW_LINK)
        self.grasp = Grasp(e, self.arm.body_entity_ids[:, tip], JAW_GRASP_POINT, self.grasp_reach)
        tip_rows = self.arm.body_rows[:, tip].cpu().numpy().astype(np.uint32)
        limits = {j.name: j.limit for j in self.arm.urdf.robot.joints}
        extra = {"arm_joints": e.create_shared_buffer("arm_joints", (n, 12), "float32"),
                 "arm_start": e.create_shared_buffer("arm_start", 6, "float32"),
                 "arm_limits": e.create_shared_buffer("arm_limits", (3, 6), "float32"),
                 "tip_bodies": e.create_shared_buffer("tip_bodies", n, "uint32"),
                 "target_candidates": e.create_shared_buffer("target_candidates", len(self.target_particles),
                                                             "uint32"),
                 "task_state": e.create_shared_buffer("task_state", (n, 4), "uint32")}
        extra["arm_start"].write(np.asarray(self.start_q, np.float32))
        extra["arm_limits"].write(np.array([[limits[j].lower for j in JOINTS], [limits[j].upper for j in JOINTS],
                                            ACTION_SCALE], np.float32))
        extra["tip_bodies"].write(tip_rows)
        extra["target_candidates"].write(self.target_particles)
        self.buffers.extra = extra
        return super()._create_passes()

    def _find_targets(self):
        """The flap's particles (env-relative) that a target is drawn from: its free edge's top
        layer (the lowest y, the highest z of its rest shape), checked to be alike in every env."""
        mapping = self.engine.particle_mapping
        entity_name = {int(i): self._world.entity(int(i)).name for i in mapping["object_entity"]}
        flaps = [k for k, entity in enumerate(mapping["object_entity"]) if entity_name[int(entity)] == FLAP]
        offsets = mapping["object_offset"][flaps] - mapping["env_offset"][mapping["object_env"][flaps]]
        if len(flaps) != self.num_envs or np.any(offsets != offsets[0]):
            raise RuntimeError("TissueRetract: the flap is not at the same place in every env's particles")
        first, count = int(mapping["object_offset"][flaps[0]]), int(mapping["object_count"][flaps[0]])
        rest = self.engine.buffer("particles.initial_positions").read()[first:first + count, :3]
        edge = (rest[:, 1] < rest[:, 1].min() + 1e-6) & (rest[:, 2] > rest[:, 2].max() - 1e-6)
        self.target_particles = (np.nonzero(edge)[0] + int(offsets[0])).astype(np.uint32)
        self.particles_per_env = int(mapping["env_count"][0])
        self.target_rest = rest[edge]  # (candidates, 3): where each candidate rests, env frame

    def task_bindings(self) -> dict:
        return {**self.buffers.extra, "grasps": self.grasp.commands, "grasp_points": self.grasp.points,
                "arm_joint_values": self.arm.link_poses.joint_values,
                "particle_positions": "particles.positions", "initial_positions": "particles.initial_positions",
                "particle_env_ranges": "particles.env_ranges", "body_positions": "rigid.positions",
                "body_rotations": "rigid.rotations"}

    def task_constants(self, reset_all: bool) -> dict:
        return {"envs": self.num_envs, "max_steps": self.max_episode_steps, "reset_all": int(reset_all),
                "seed": self.seed, "candidates": len(self.target_particles), "target_lift": self.target_lift,
                "length_scale": LENGTH_SCALE, "frame": FRAME, "jaw_open": JAW_OPEN, "jaw_closed": JAW_CLOSED,
                "crtk": int(self.observation == "crtk"), "absorbing_success": int(self.absorbing_success)}

    # --- a step ---------------------------------------------------------------------------------
    def act(self):
        """The task's `apply_action`, the arm's FK pass, then the grasp pass."""
        self.engine.execute_compute_pass(self.passes["apply_action"])
        self.arm.pose()
        self.grasp.execute()
