"""A dVRK patient cart in one engine, without ROS: the ECM with a stereo endoscope and several PSMs.

    cart = Cart(TwinConfig(scene=load_scene("patient_cart.yaml")))
    cart.groups[0][0]                          # the PSMs: one TwinArms, a row per PSM (per instrument)
    cart.psms[0]                               # PSM1's row of it (views of its state, its own bodies)
    cart.ecm                                   # the ECM's joints and state (EcmArm)
    events = cart.tick()                       # every arm one control period; (row, topic, value) events
    cart.step_engine(render=True)              # every arm's links and both cameras posed, physics, render
    left, right = cart.images(["color"])["color"]

One world. The scene file's `cart:` names the arms (ECM, PSM1..3, MTML, MTMR) and where each
base (the RCM) is: given, or where the dVRK's setup joints hold it (cressim.robots.suj). Every
PSM and the ECM is an ArmBodies of that world with a collision group of its own; the scenery is
the table and tissue block, or the scene's `world` file (simulated every tick when it has
particles); one engine steps them all. The arms are kinematic: their links follow the twin's
measured joints, so the engine lets them pass through each other, and each tick the cart checks
where their instruments would touch instead (cressim.twin.arm_clearance).

Rows. To the ROS node the cart looks like TwinArms with one row per PSM (row k is `names[k]`,
published under /PSMk). The PSMs are ticked together: one TwinArms per instrument (all of them
when they carry the same tool), a row per PSM over their bodies (cressim.twin.arm_rows.ArmRows),
so a tick is one batched pass over every PSM, whatever their number. Every command `(row, ...)` goes to
that row, and the events come back with the cart's row. The ECM (EcmArm) and the MTMs
(cressim.twin.mtm, with the operator who holds them) have their own objects and topics. The
PSMs' measured_cp is expressed in the endoscope's frame (the ECM's tip, following it) until a
client sets a base frame.

The stereo endoscope. Two pinhole cameras of the scene's `camera:` size and field of view sit on
the ECM's tip (DH frame 4, z out of the scope), `endoscope.baseline` apart along the tip's x,
with the same orientation: a rectified pair (rows match; a point at depth Z shows a disparity
of fx B / Z pixels). Each is a kinematic body whose target is the ECM's measured tip pose, so the
images follow the ECM in the frame they are rendered.
"""
from __future__ import annotations

import dataclasses
import threading

import numpy as np
import torch
import yourdfpy

import cressim
from cressim.robots import robot_dir
from cressim.robots.arm_bodies import ArmBodies, _link_shapes
from cressim.robots.ecm import ecm_urdf
from cressim.robots.ecm import ecm_forward_kinematics, ecm_inverse_kinematics
from cressim.robots.kinematics import matrix_to_pose7, pose7_to_matrix, rotation_xyzw
from cressim.scene_file import add_scene

from .arm_rows import ArmRows
from .arm_clearance import INSTRUMENT_RADIUS, SCOPE_RADIUS, ArmClearance
from .arms import TwinArms, TwinConfig
from .camera_images import CameraImages
from .ecm_arm import EcmArm
from .messages import ConfigError, Event, JointCommand, Snapshot
from .mtm import MtmArm, Operator, ScriptedOperator
from cressim.twin_scene_file import ECM_HOME
from .scenery import TABLE_COLOR, TABLE_HALF, TISSUE_COLOR, TISSUE_HALF, CameraSpec, SceneryPlan, look_at_rotation
from .sensor_loop import process_threads

EYES = ("left", "right")
FIRST_GROUP_BIT = 8  # arm k's links are collision group 1 << (8 + k): clear of the scene files' groups
IDS_PER_ARM = 32  # segmentation ids: arm k's bodies from 1 + 32 k; the scenery's after every arm's


def _geometry_links(urdf_path) -> int:
    urdf = yourdfpy.URDF.load(str(urdf_path), build_scene_graph=False, load_meshes=False)
    return sum(1 for link in urdf.robot.links if _link_shapes(link))


@dataclasses.dataclass
class CartScenery:
    """What the node needs of the cart's scenery: the eyes' camera, segmentation labels."""
    camera: CameraSpec
    labels: dict
    baseline: float
    ultrasound: None = None


class Cart:
    def __init__(self, config: TwinConfig):
        scene = config.scene
        if config.value("num_envs") != 1:
            raise ConfigError(f"{scene.path}: num_envs: a patient cart runs in one env "
                              f"(got {config.value('num_envs')})")
        if config.value("dynamics") != "kinematic":
            raise ConfigError(f"{scene.path}: dynamics: a patient cart's arms are kinematic "
                              f"(got {config.value('dynamics')})")
        self.scene = scene
        self.publish_rate, self.physics_rate = config.value("publish_rate"), config.value("physics_rate")
        psm_specs = [a for a in scene.cart if a.kind == "psm"]
        ecm_spec = next(a for a in scene.cart if a.kind == "ecm")
        self.mtm_specs = [a for a in scene.cart if a.kind == "mtm"]
        self.names = [a.name for a in psm_specs]
        self.robot = psm_specs[0].robot
        camera = CameraSpec(width=config.value("camera_width"), height=config.value("camera_height"),
                            fov_y=scene.camera_fov_y, near=0.005, far=2.0)
        plan = SceneryPlan(camera, None, scene.world)
        urdfs = [robot_dir() / f"{a.robot}.urdf" for a in psm_specs] + [ecm_urdf()]
        limits = plan.layout_limits(sum(_geometry_links(u) for u in urdfs))
        limits["max_cameras_per_env"] = len(EYES)
        world = cressim.World(cressim.SceneLayout(1, **limits))
        before = process_threads()

        # the arms, each in a collision group of its own
        arm_bodies, labels = [], {}
        for k, (spec, urdf) in enumerate(zip(psm_specs + [ecm_spec], urdfs)):
            ecm = spec.kind == "ecm"
            initial = np.zeros(6)
            initial[: 4 if ecm else 6] = spec.initial_jp or (ECM_HOME if ecm else scene.initial_jp)
            bodies = ArmBodies(urdf, 1, base_position=spec.base_position, base_rotation=spec.base_rotation,
                               publish_rate=self.publish_rate, physics_rate=self.physics_rate, initial_q=initial,
                               initial_jaw=0.0 if ecm else scene.initial_jaw, dof=4 if ecm else 6, world=world,
                               collision_group=1 << (FIRST_GROUP_BIT + k), name=spec.name)
            first = 1 + IDS_PER_ARM * k
            bodies.show(world, [0], first_id=first)
            # the URDF says PSM1_* for every PSM: each arm's bodies under its own name (PSM2_shaft_link)
            labels.update({first + j: name.replace("PSM1_", f"{spec.name}_")
                           for j, name in enumerate(bodies.body_names)})
            arm_bodies.append(bodies)
        self.ecm_bodies = arm_bodies[-1]

        # the scenery: a world file, or the table and tissue block; a light from above
        first = 1 + IDS_PER_ARM * len(arm_bodies)
        if scene.world:
            labels.update(add_scene(world, scene.world, segmentation_offset=first - 1).labels)
        else:
            for name, mesh, z, color, label in (
                    ("table", cressim.Mesh.plane(TABLE_HALF), camera.table_z, TABLE_COLOR, first),
                    ("tissue", cressim.Mesh.box(TISSUE_HALF), camera.table_z + TISSUE_HALF[2], TISSUE_COLOR,
                     first + 1)):
                e = world.create_entity(env=0, name=name)
                e.add(cressim.Transform(position=(0.0, 0.0, z)))
                e.add(cressim.Renderable(world.add_mesh(mesh), color=color, roughness=0.5, segmentation_id=label))
                labels[label] = name
        light = world.create_entity(env=0, name="light")
        light.add(cressim.Transform(rotation=look_at_rotation((0.2, -0.3, 1.0), (0.0, 0.0, 0.0))))
        light.add(cressim.Light(intensity=1.0, ambient=0.3))

        # the endoscope's two cameras, kinematic bodies that follow the ECM's tip
        self.ecm = EcmArm(ecm_spec.initial_jp or ECM_HOME, ecm_spec.home_jp or ECM_HOME,
                          measured_lag=scene.measured_lag, name=ecm_spec.name, publish_rate=self.publish_rate)
        self.baseline = scene.endoscope_baseline
        self.ecm_base = pose7_to_matrix(np.array([*ecm_spec.base_position, *ecm_spec.base_rotation]))
        fx, fy, cx, cy = camera.intrinsics()
        self.camera_entities = []
        for eye, pose in zip(EYES, self.eye_poses()):
            e = world.create_entity(env=0, name=f"endoscope_{eye}")
            e.add(cressim.Transform(position=tuple(map(float, pose[:3, 3])), rotation=rotation_xyzw(pose[:3, :3])))
            e.add(cressim.RigidBody(mass=0.01, inertia=(1e-6, 1e-6, 1e-6), kinematic=True))
            e.add(cressim.Camera(width=camera.width, height=camera.height, fx=fx, fy=fy, cx=cx, cy=cy,
                                 near=camera.near, far=camera.far))
            self.camera_entities.append(e.id)

        engine = cressim.Engine(world, device=config.device)
        engine.physics = cressim.PhysicsSettings(dt=1.0 / self.publish_rate,
                                                 substeps=int(round(self.physics_rate / self.publish_rate)),
                                                 gravity=(0.0, 0.0, -9.81), **plan.physics_settings())
        engine.prepare()
        engine.upload_world()
        for bodies in arm_bodies:
            bodies.bind(engine, cuda_stream=True)
        self.engine = engine
        self.engine_threads = process_threads() - before
        body_entity = np.asarray(engine.buffer("rigid.body_entity").read()).astype(np.int64)
        row_of = {int(e): row for row, e in enumerate(body_entity)}
        self._camera_rows = torch.as_tensor([row_of[e] for e in self.camera_entities], dtype=torch.long)
        self._images = CameraImages(engine)
        self.scenery = CartScenery(camera, labels, self.baseline)
        self.bodies = self  # what the node reads of `arms.bodies` (engine, scenery, device)
        self.simulated = plan.simulated()
        self.device = arm_bodies[0].device
        self.engine_lock = threading.Lock()

        # the PSMs ticked together: one TwinArms per instrument (usually one), a row per PSM, over
        # the bodies above (ArmRows); the cart's row k is PSM k, wherever its TwinArms keeps it
        self.psm_bases = np.stack([pose7_to_matrix(np.array([*s.base_position, *s.base_rotation])) for s in psm_specs])
        self.groups, self._where = [], [None] * len(psm_specs)
        for robot in dict.fromkeys(s.robot for s in psm_specs):
            rows = [k for k, s in enumerate(psm_specs) if s.robot == robot]
            specs = [psm_specs[k] for k in rows]
            home = [s.home_jp or scene.home_jp or [np.nan] * 6 for s in specs]
            arm_scene = dataclasses.replace(scene, arm=specs[0].name, robot=robot, cart=())
            arms = TwinArms(TwinConfig(scene=arm_scene, num_envs=len(rows), cameras=False,
                                       publish_rate=self.publish_rate, physics_rate=self.physics_rate,
                                       particle_rate=self.physics_rate, device=config.device),
                            bodies=ArmRows([arm_bodies[k] for k in rows]),
                            initial_jp=[s.initial_jp or scene.initial_jp for s in specs], home_jp=home,
                            names=[s.name for s in specs])
            self.groups.append((arms, rows))
            for r, k in enumerate(rows):
                self._where[k] = (arms, r)
        self.psms = [PsmRow(name, *self._where[k], arm_bodies[k]) for k, name in enumerate(self.names)]
        self._order = np.argsort(np.concatenate([rows for _, rows in self.groups]))  # snapshot rows -> cart rows
        self.num_envs = len(self.psms)  # the node's rows
        self.arm = self.names[0]
        self.psm = self.psms[0].psm
        self.dynamic = False
        self.ecm_events = []  # the ECM's events of the last tick, for its topics
        self.clearance = ArmClearance()
        # the PSMs' measured_cp in the endoscope's frame (the dVRK console's), until a client sets one
        self.own_base_frame = [False] * self.num_envs
        self._follow_camera()

        # the surgeon's console: the MTMs and the operator who holds them (a script, or a device)
        self.mtms = [MtmArm(a.name) for a in self.mtm_specs]
        self.operator = Operator([m.name for m in self.mtms])
        self.script = ScriptedOperator(list(scene.operator)) if scene.operator else None
        self._camera_start = None  # while the camera pedal moves the ECM: (hands' midpoint, tip) at the press

    # ------------------------------------------------------------------ the endoscope
    def eye_poses(self) -> list[np.ndarray]:
        """World poses (4x4) of the left and right camera (optical frames: z forward, x right)."""
        tip = self.ecm_base @ self.ecm.local_cp("measured")
        out = []
        for side in (-0.5, 0.5):
            T = tip.copy()
            T[:3, 3] += side * self.baseline * tip[:3, 0]
            out.append(T)
        return out

    def eye_offsets(self) -> list[np.ndarray]:
        """The eyes' poses in the ECM's tip frame (what /tf_static says: ECM -> camera frames)."""
        out = []
        for side in (-0.5, 0.5):
            T = np.eye(4)
            T[0, 3] = side * self.baseline
            out.append(T)
        return out

    def ecm_joints(self) -> tuple[torch.Tensor, torch.Tensor]:
        """The ECM's measured joints as ArmBodies takes them: (1, 6) (4 used) and a (1, 1) jaw of 0."""
        q = torch.zeros(1, 6, dtype=torch.float64)
        q[0, :4] = self.ecm.measured[0]
        return q, torch.zeros(1, 1, dtype=torch.float64)

    def images(self, products) -> dict:
        """product -> [left, right] host images of the last rendered frame."""
        return self._images.read(products)

    # ------------------------------------------------------------------ rows (the node's TwinArms face)
    def label(self, row: int) -> str:
        return self.names[row]

    def _rows(self, rows, events):
        """A TwinArms' events with the cart's row numbers (`rows`: its rows' cart rows)."""
        return [Event(rows[e.env], e.topic, e.value) for e in events]

    def __getattr__(self, name):
        if name in ROW_COMMANDS:
            def command(row, *args, **kwargs):
                if name in MOTION_COMMANDS and self._camera_start is not None:
                    kind = name.replace("jaw_", "jaw/")
                    return [Event(row, "warning", f"{kind} refused: the camera pedal is pressed (the ECM follows "
                                                  "the operator's hands, the PSMs hold)")]
                arms, r = self._where[row]
                return [Event(row, e.topic, e.value) for e in getattr(arms, name)(r, *args, **kwargs)]
            return command
        raise AttributeError(name)

    def instrument(self, name: str):
        """The cart's PSMs carry no instrument plug-ins: their arms are kinematic over the world."""
        return None

    def report(self, row: int):
        arms, r = self._where[row]
        return arms.report(r)

    def forward(self, row, cmd, *, local):
        arms, r = self._where[row]
        return arms.forward(r, cmd, local=local)

    def inverse(self, row, pose, seed=None):
        arms, r = self._where[row]
        return arms.inverse(r, pose, seed)

    @property
    def sim_ns(self) -> int:
        return self.groups[0][0].sim_ns

    @property
    def ticks(self) -> int:
        return self.groups[0][0].ticks

    @property
    def period_ns(self) -> int:
        return self.groups[0][0].period_ns

    def set_rate(self, publish_rate: float):
        for arms, _ in self.groups:
            arms.set_rate(publish_rate)
        self.ecm.period_ns = self.groups[0][0].period_ns
        self.publish_rate = publish_rate

    def restart(self, *, clock: bool = True):
        for arms, _ in self.groups:
            arms.restart(clock=clock)
        self.ecm.restart()
        for mtm in self.mtms:
            mtm.restart()
        self.operator = Operator([m.name for m in self.mtms])
        self.own_base_frame = [False] * self.num_envs
        self._follow_camera()
        self.clearance = ArmClearance()
        self._camera_start = None

    def camera_frame(self) -> np.ndarray:
        """The endoscope's frame (the ECM's tip, `ECM`) in the world: what the PSMs' measured_cp
        is expressed in, as on the dVRK with an ECM."""
        return self.ecm_base @ self.ecm.local_cp("measured")

    def _follow_camera(self, *, changed: bool = True):
        """Every PSM's base frame (batched): its base in the endoscope's frame, unless a client set
        one. Only when the endoscope moved (or `changed`: a restart, a base frame given back)."""
        camera = self.camera_frame()
        if not changed and np.array_equal(camera, self._camera_at):
            return
        self._camera_at = camera
        T = np.linalg.solve(camera[None], self.psm_bases)  # (N, 4, 4)
        for arms, rows in self.groups:
            own = np.array([self.own_base_frame[k] for k in rows])
            if not own.all():
                mine = np.flatnonzero(~own)
                arms.base_frame_np[mine] = T[np.asarray(rows)[mine]]
                arms.base_frame[mine] = torch.as_tensor(arms.base_frame_np[mine])

    def set_base_frame(self, row: int, pose):
        """A client's base frame replaces the camera's for that PSM."""
        arms, r = self._where[row]
        events = [Event(row, e.topic, e.value) for e in arms.set_base_frame(r, pose)]
        if not events:
            self.own_base_frame[row] = True
        return events

    def tick(self) -> list:
        """Every arm one control period; the PSMs' events by row (the ECM's in `ecm_events`)."""
        events = []
        for arms, rows in self.groups:  # all PSMs of an instrument in one batched tick
            events += self._rows(rows, arms.tick())
        dt = self.period_ns * 1e-9
        self.ecm_events = pairs(self.ecm.tick())
        self._follow_camera(changed=False)
        if self.script is not None:
            self.script.apply(self.sim_ns * 1e-9, self.operator)
        for mtm in self.mtms:
            mtm.tick(dt, self.operator)
        events += self._camera_control()
        events += self._clearance()
        if self.simulated:  # the world's particles move by themselves: physics every tick
            with self.engine_lock:
                self._pose()
                self.engine.step_physics()
                self.engine.end_frame()
        return events

    def snapshot(self, **kwargs) -> Snapshot:
        """Every PSM's published state, by cart row (one snapshot per instrument's TwinArms)."""
        snaps = [arms.snapshot(**kwargs) for arms, _ in self.groups]
        if len(snaps) == 1:
            return snaps[0]
        return Snapshot(snaps[0].sim_ns, {k: np.concatenate([s.fields[k] for s in snaps])[self._order]
                                          for k in snaps[0].fields})

    def _camera_control(self) -> list:
        """The camera pedal, as the dVRK console's ECM teleoperation: pressed with the operator
        present and the ECM enabled and homed, the endoscope follows the operator's hands, the
        PSMs hold. The midpoint of the MTMs' grips (their base frames are aligned with the
        display, so with the camera) moves the scope's tip as much in the camera's frame at the
        press (left/right and up/down turn the ECM about its RCM, in/out inserts it; the roll
        keeps the image level as at the press); the ECM gets it as a servo_jp each tick, within
        its limits. PSM events: the holds at the press."""
        op, ecm = self.operator, self.ecm
        state = ecm.states[0]
        on = bool(self.mtms) and op.camera and op.present and state.state == "ENABLED" and state.is_homed
        if not on:
            if self._camera_start is not None:
                self._camera_start = None
                self.ecm_events.append(("status", f"{ecm.name}: camera control released"))
            return []
        hands = np.mean([m.pose[:3, 3] for m in self.mtms], axis=0)
        events = []
        if self._camera_start is None:  # the press: the PSMs stop where they are
            self._camera_start = (hands, ecm.local_cp("setpoint"))
            self.ecm_events.append(("status", f"{ecm.name}: camera control: the endoscope follows the hands"))
            for row in range(self.num_envs):
                arms, r = self._where[row]
                events += [Event(row, e.topic, e.value) for e in arms.hold(r)]
        start, tip = self._camera_start
        goal = tip.copy()
        goal[:3, 3] = tip[:3, 3] + tip[:3, :3] @ (hands - start)
        q, _ = ecm_inverse_kinematics(goal)  # the nearest the scope reaches (its z stays as at the press)
        self.ecm_events += pairs(ecm.servo_jp(0, JointCommand(position=q.tolist())))
        return events

    def _clearance(self) -> list:
        """The PSMs' instruments and the ECM's scope that start or stop touching (arm_clearance):
        a warning, then a status, on each arm of the pair."""
        capsules = {}
        for arms, rows in self.groups:  # every PSM's instrument in one batched call
            ends = arms.kin.instrument(arms.measured).numpy()  # (M, 2, 3): tool base, jaw pivot
            B = self.psm_bases[rows]
            F = B[:, None, :3, :3] @ ends[..., None] + B[:, None, :3, 3:]
            for r, k in enumerate(rows):
                capsules[self.names[k]] = (F[r, 0, :, 0], F[r, 1, :, 0], INSTRUMENT_RADIUS)
        F = self.ecm_base @ ecm_forward_kinematics(self.ecm.measured[0].numpy(), all_frames=True)
        capsules[self.ecm.name] = (F[2, :3, 3], F[3, :3, 3], SCOPE_RADIUS)
        onsets, partings = self.clearance.update(capsules)
        events = []
        for pairs, topic, text in ((onsets, "warning", "collides with {} (their instruments touch)"),
                                   (partings, "status", "clear of {}")):
            for a, b in pairs:
                for name, other in ((a, b), (b, a)):
                    if name == self.ecm.name:
                        self.ecm_events.append((topic, text.format(other)))
                    else:
                        events.append(Event(self.names.index(name), topic, f"{name}: {text.format(other)}"))
        return events

    def step_engine(self, *, render: bool = False, sense: bool = False):
        """A sensor frame. Over a still world the arms' links and the eyes are posed at the measured
        joints and stepped here; over a world that moves by itself (particles) that ran in the
        tick, so only the cameras run. Call with `engine_lock` held."""
        if not self.simulated:
            self._pose()
            self.engine.step_physics()
        if render:
            self.engine.step_visual_sensors()
        self.engine.end_frame()

    def _pose(self):
        """Every arm's links at its measured joints and the eyes on the ECM's tip (GPU targets)."""
        for arms, _ in self.groups:
            arms.bodies.write(arms.measured, arms.jaw_meas)
        self.ecm_bodies.write(*self.ecm_joints())
        p7 = matrix_to_pose7(torch.as_tensor(np.stack(self.eye_poses())))
        targets = torch.from_dlpack(self.engine.buffer("control.body_target_positions"))
        rotations = torch.from_dlpack(self.engine.buffer("control.body_target_rotations"))
        rows = self._camera_rows.to(targets.device)
        targets[rows, :3] = p7[:, :3].to(targets)
        rotations[rows] = p7[:, 3:].to(rotations)


class PsmRow:
    """One PSM of the cart as a one-env TwinArms looks (what tests and the benchmark read): its row
    of the batched state (views at the time of reading, so writes go through), its own bodies."""

    num_envs = 1

    def __init__(self, name, arms, row, bodies):
        self.arm, self.arms, self.row, self.bodies = name, arms, row, bodies
        self.psm, self.kin = arms.psm, arms.kin

    def __getattr__(self, name):
        if name in ("measured", "setpoint", "jaw_meas", "jaw_sp", "measured_v", "setpoint_v"):
            return getattr(self.arms, name)[self.row: self.row + 1]
        if name == "states":
            return [self.arms.states[self.row]]
        raise AttributeError(name)


def pairs(events) -> list:
    """An arm model's events as the (topic, value) pairs a single arm's topics take (the ECM's)."""
    return [(e.topic, e.value) for e in events]


MOTION_COMMANDS = ("servo_jp", "move_jp", "servo_cp", "move_cp", "servo_cv", "jaw_servo_jp", "jaw_move_jp")
ROW_COMMANDS = ("state_command", "servo_jp", "move_jp", "servo_cp", "move_cp", "servo_cv", "jaw_servo_jp",
                "jaw_move_jp", "instrument_command", "hold", "set_ratio", "ratio_events", "set_flag")

__all__ = ["Cart", "CartScenery", "EYES", "pairs"]
