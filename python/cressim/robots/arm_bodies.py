"""An arm's URDF links as rigid bodies in a cressim engine, one arm per env, kinematic or dynamic.

Kinematic (`arm.dynamics: kinematic`, the default). Each URDF link with collision geometry
becomes one kinematic rigid body whose colliders are the link's collision primitives (cylinder
-> capsule of the same radius and length, box, sphere). Every tick the twin writes all envs'
joint values, and the GPU's FK pass (link_poses.hlsl on the compiled URDF chain,
cressim.robots.chain) poses every link body's target, times the arm's base pose. The engine bodies
follow the twin's own joint state, so contacts see the arm's motion (and its speed: kinematic
bodies cover their way in equal shares per substep) but never push it back.

Dynamic (`arm.dynamics: dynamic`), for any URDF whose arm joints (with limits) form a serial
chain from the base to the tip link. The arm is that chain's equivalent serial chain of dynamic
bodies connected by engine joints, one per arm joint (the PSM: yaw hinge on the world, the base
being fixed; pitch hinge about the RCM; insertion slider; roll, wrist pitch and wrist yaw
hinges), and one hinge per link hung off that way by the jaw (the PSM's blades, each at +-1/2 of
the jaw angle, as the URDF's mimic joints). Body k carries the links that move rigidly with the
last link that joint k moves on the way to the tip (its reference link), found numerically:
a link's pose relative to it is constant over random joint values. Joint k's axis is the screw
that takes reference link k - 1 to reference link k (the PSM's parallelogram of mimic joints
turns the pitch_front link about the RCM: one hinge there), checked to be one fixed axis. The
links that ride on no body (the parallelogram's back, top and bottom bars) and the mount stay
kinematic and follow FK of the measured joints, one tick behind. Joint coordinates are the
arm joints' values (the bodies are authored at q = 0 and posed at the initial values by the
engine's reset), so the engine's limits are the URDF limits, and measured values are
`joint.positions` / `joint.velocities` gathered with one index tensor for all envs.

What the engine's XPBD solver (Gauss-Seidel over the joints, 1-4 iterations) needed, found by
experiment (docs/twin.md, "Dynamic arm", has the numbers):
- body origins on the joints (`_mass_properties`): a body's origin (which the engine takes for
  its centre of mass) sits where its joints meet on its axis, with the links' inertia about that
  point; with origins at the links' centres of mass the yaw drifted by 0.7 rad under gravity
  even with rigid drives;
- armature (reflected motor inertia) on yaw and pitch and a little on roll: the drive acts on
  its child body alone, and a light child under a heavy subtree made the drives weak;
- no engine damping on the light joints (roll, wrist, jaw): the engine's damping is a
  constraint toward rest solved after the drive, and on bodies this light it cancelled the
  drive (the joint stalled);
- in the twin, per joint and env, batched (`set_targets`): a velocity-limited ramp of the
  command, gravity feed-forward, velocity feed-forward, damping of the velocity error on yaw and
  pitch, a bounded integral term at rest, clamping to the limits.
Segmentation: `link_names` and `link_entity_ids` ((num_envs, num_links) int64) map every link
with geometry to the entity that carries it in each env (one entity per link, except links
merged into one dynamic body, such as the suction tube on the shaft, which share it).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import torch

import cressim
from .arm_visuals import ArmVisuals
from .chain import PRISMATIC, REVOLUTE, Chain, load_urdf, rotation_xyzw, screw_motion
from .dvrk import JAW, PSM_JOINTS
from .kinematics import matrix_to_pose7
from .link_poses import LinkPoses
from .psm import JAW_GRASP_POINT, JAW_LINK, TIP_LINK
from ..suture import needle_arrays, needle_body

ARM_GROUP = 2  # collision group of arm links; they do not collide with each other (mask below)
COLLIDER_NO_PARTICLES = 0x80000000  # in a collider's group: particles pass through it (shaders/common/rigid.h)
NEEDLE_WIRE = 0.00035  # m: a 2-0 needle's wire radius (drawn, collided and weighed)
NEEDLE_SEGMENTS = 6  # capsules along a needle's arc
DYNAMICS = ("kinematic", "dynamic")

# Position drives of the dynamic arm: (stiffness, damping, max force) per joint, SI units
# (N m/rad, N m s/rad, N m for hinges; N/m, N s/m, N for the insertion slider; per jaw blade).
# - max force = the dVRK's maximum joint effort (shared/DVRK.md: 3.316, 3.316, 9.878, 0.33,
#   0.25, 0.20 N m / N; jaw 0.16 N m, which each blade gets).
# - stiffness = max effort / saturation error, the error at which the drive gives its full
#   effort: 0.01 rad for the arm's hinges, 1 mm for the insertion, 0.005 rad per jaw blade.
# - damping (the engine's, toward rest) = max effort / (2 x the URDF velocity limit: 2 rad/s,
#   0.4 m/s) on yaw, pitch and insertion: it is capped by max force too, so more would cap the
#   joint's speed (at max force / damping); the twin cancels it while moving (velocity
#   feed-forward). 0 on the light joints (module docstring).
DRIVES = {
    "yaw": (331.6, 0.829, 3.316),
    "pitch": (331.6, 0.829, 3.316),
    "insertion": (9878.0, 12.35, 9.878),
    "roll": (33.0, 0.0, 0.33),
    "wrist_pitch": (25.0, 0.0, 0.25),
    "wrist_yaw": (20.0, 0.0, 0.20),
    "jaw": (32.0, 0.0, 0.16),
}
# reflected motor inertia added about the joint axis, kg m^2 (module docstring)
ARMATURE = {"yaw": 0.1, "pitch": 0.1, "roll": 1e-5, "wrist_pitch": 0.0, "wrist_yaw": 0.0, "jaw": 0.0}
# the twin's damping of the velocity error (command - measured), N m s/rad, added to the target
TWIN_DAMPING = {"yaw": 10.0, "pitch": 10.0}
MAX_HINGE_STEP = 1.0  # rad (see ArmBodies.set_targets)
INTEGRAL_TIME = 0.5  # s: integral term of the dynamic arm's drives (see ArmBodies.set_targets)
INTEGRAL_LIMIT = 0.5  # its bound, as a share of the drive's saturation error (max force / stiffness)
SOLVER_ITERATIONS = 2  # dynamic arm: XPBD iterations per substep (4 and more let the insertion creep down)
# floors of the light wrist and jaw bodies (kg, kg m^2): with the links' own 1e-8 kg m^2 the
# solver corrected gravity's pull on the wrist_yaw body (9 mm off the wrist pitch axis) by turning
# the wrist pitch, which then sat 0.015 rad off its setpoint per 0.4 rad of wrist pitch
MIN_MASS, MIN_INERTIA = 1e-3, 1e-6
RIGID_TOLERANCE = 1e-6  # link pose relative to a reference link constant within this: it rides on its body
# drives of joints DRIVES does not name (another URDF): the same rules as DRIVES' from the URDF's
# effort and velocity limits, with these saturation errors (rad, m)
SATURATION = {REVOLUTE: 0.01, PRISMATIC: 0.001}


def _shape(geometry, origin: np.ndarray):
    position, rotation = tuple(float(v) for v in origin[:3, 3]), rotation_xyzw(origin[:3, :3])
    if geometry.box is not None:
        return cressim.Shape.box(tuple(float(s) / 2 for s in geometry.box.size), position=position, rotation=rotation)
    if geometry.cylinder is not None:  # a capsule as long as the cylinder, both along z
        r, length = float(geometry.cylinder.radius), float(geometry.cylinder.length)
        return cressim.Shape.capsule(r, max(length / 2 - r, 1e-4), position=position, rotation=rotation)
    if geometry.sphere is not None:
        return cressim.Shape.sphere(float(geometry.sphere.radius), position=position, rotation=rotation)
    return None  # meshes: the engine has no mesh colliders; the link is shown only


def _link_shapes(link, frame=np.eye(4)):
    """The link's collision primitives, posed in `frame` (a 4x4 from the body frame to the link)."""
    out = []
    for c in link.collisions:
        s = _shape(c.geometry, frame @ (c.origin if c.origin is not None else np.eye(4)))
        if s is not None:
            out.append(s)
    return out


def _quat_matrices(q: torch.Tensor) -> torch.Tensor:
    """(M, 4) xyzw (the engine's order) -> (M, 3, 3)."""
    x, y, z, w = q.unbind(-1)
    return torch.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),
                        2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
                        2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1).reshape(-1, 3, 3)


def _quat_matrix(x, y, z, w) -> np.ndarray:
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def _drive(name, kind, joint):
    """(stiffness, damping, max force) of an arm joint: DRIVES', or for a joint it does not name the
    same rules from the URDF's effort and velocity limits (stiffness = effort / saturation error,
    damping = effort / (2 x velocity limit))."""
    if name in DRIVES:
        return DRIVES[name]
    effort, velocity = float(joint.limit.effort), float(joint.limit.velocity)
    if not (effort > 0 and velocity > 0):
        raise ValueError(f"dynamic arm: joint {name} needs effort and velocity limits in the URDF")
    return (effort / SATURATION[kind], effort / (2 * velocity), effort)


def _nearest_on(line, other):
    """The point of `line` ((direction, point, kind)) nearest `other`; None where they are parallel."""
    a1, p1, _ = line
    a2, p2, _ = other
    n = np.cross(a1, a2)
    if np.linalg.norm(n) < 1e-9:
        return None
    return p1 + a1 * (np.cross(p2 - p1, a2) @ n) / (n @ n)


def _meeting_point(axes, i, fallback):
    """Body i + 1's origin (see ArmBodies._plan_dynamic) for a hinge: on its axis where the next
    hinge's (else the previous one's) comes nearest, else `fallback` projected on it; for a
    slider `fallback`."""
    a, p, kind = axes[i]
    if kind != REVOLUTE:
        return np.asarray(fallback, dtype=np.float64)
    for j in (i + 1, i - 1):
        x = _nearest_on(axes[i], axes[j]) if 0 <= j < len(axes) and axes[j][2] == REVOLUTE else None
        if x is not None:
            return x
    return p + a * ((fallback - p) @ a)


def _frame_along(T, axis) -> np.ndarray:
    """T's rotation, turned the least way that puts its z on `axis` (the body frame's z is its
    joint's axis: armature goes there)."""
    out = np.array(T, dtype=np.float64)
    z = out[:3, 2]
    c = float(z @ axis)
    n = np.cross(z, axis)
    s = float(np.linalg.norm(n))
    if s < 1e-9:  # along the axis already, or opposite it: a half turn about x
        if c < 0:
            out[:3, :3] = out[:3, :3] @ np.diag([1.0, -1.0, -1.0])
        return out
    out[:3, :3] = screw_motion(n / s, np.zeros(3), REVOLUTE, math.atan2(s, c))[:3, :3] @ out[:3, :3]
    return out


class _Body:
    """A body being authored: links, world pose at q = 0, mass properties."""

    def __init__(self, name, frame):
        self.name, self.frame, self.links = name, frame, []  # frame: 0 kinematic, k arm joint k, "jaw:<joint>"
        self.pose = np.eye(4)
        self.mass, self.inertia = 0.0, (0.0, 0.0, 0.0)


class ArmBodies:
    """num_envs arms (links as kinematic or dynamic bodies) in one engine.

    Joint order everywhere: the arm joints (`joints`, default the PSM's first `dof` interface
    joints: a 4-dof tool ignores the wrist ones), then the jaw (a column no joint reads for an arm
    without one). `write` poses the kinematic bodies; in dynamic mode `set_targets` drives the
    joints and `read_joints` returns the simulated joint values.
    """

    def __init__(self, urdf_path, num_envs: int, *, base_position, base_rotation, publish_rate: float,
                 physics_rate: float, initial_q: np.ndarray, initial_jaw: float, dof: int, device=None,
                 dynamics: str = "kinematic", gravity=(0.0, 0.0, -9.81), scenery=None,
                 world: cressim.World | None = None, needle: dict | None = None, particle_rate: float = 0.0,
                 collision_group: int = ARM_GROUP, name: str = "arm", arm_joints=None, tip_link: str = TIP_LINK):
        """`particle_rate`: the scenery's particles (tissue, blood, thread) substep at this rate
        (Hz; 0: physics_rate), the bodies at physics_rate. `world`: author the arm into this world (a task's, beside its own entities) instead of
        one of its own; the caller then creates the engine with its own physics settings (a dynamic
        arm wants `iterations=SOLVER_ITERATIONS`) and calls `bind(engine)` after `upload_world()`.
        `needle`: a suture needle held in the jaws (twin scene's arm.needle), with its thread.
        `collision_group`: the arm's links collide with everything but this group (one bit); arms
        of one world in groups of their own collide with each other (cressim.twin.cart). `name`:
        the prefix of the arm's shared buffers (one per arm of an engine). `arm_joints`: the arm joints'
        URDF names (another URDF than the dVRK's); `tip_link`: where the dynamic arm's serial chain
        ends (the last link its arm joints move)."""
        if dynamics not in DYNAMICS:
            raise ValueError(f"dynamics {dynamics!r} is not one of {', '.join(DYNAMICS)}")
        if world is not None and scenery is not None:
            raise ValueError("scenery is authored into the arm's own world: pass either scenery or world")
        self.num_envs, self.dof, self.dynamics, self.name = num_envs, dof, dynamics, name
        self.dynamic = dynamics == "dynamic"
        urdf = load_urdf(urdf_path)
        self.urdf, self.urdf_dir = urdf, Path(urdf_path).parent
        joints = {j.name: j for j in urdf.robot.joints}
        self.has_jaw = JAW in joints and joints[JAW].type != "fixed"
        self.joints = tuple(arm_joints) if arm_joints is not None else PSM_JOINTS[:dof]
        if len(self.joints) != dof:
            raise ValueError(f"ArmBodies: {dof} arm joints expected, got {self.joints}")
        self.tip_link = tip_link
        # every link, from the arm joints' values and the jaw's (mimic joints follow theirs)
        self.chain = Chain(urdf, sources=(*self.joints, JAW))

        base = np.eye(4)
        base[:3, :3] = _quat_matrix(*base_rotation)
        base[:3, 3] = base_position
        self.base = torch.as_tensor(base)
        self.gravity = np.asarray(gravity, dtype=np.float64)

        # links with collision geometry (segmentation covers these), in URDF order
        geometry_links = [link for link in urdf.robot.links if _link_shapes(link)]
        self.link_names = [link.name for link in geometry_links]
        q_author = np.zeros(dof) if self.dynamic else np.asarray(initial_q, dtype=np.float64)[:dof]
        jaw_author = 0.0 if self.dynamic else float(initial_jaw)
        poses = self._fk_links(torch.as_tensor(q_author[None]), torch.tensor([[jaw_author]], dtype=torch.float64))
        if self.dynamic:
            bodies, joint_specs = self._plan_dynamic(urdf, joints, poses)
        else:
            bodies, joint_specs = [], []
            for link in geometry_links:
                b = _Body(link.name, 0)
                b.links, b.pose = [link], poses[link.name]
                bodies.append(b)
        # kinematic bodies follow FK (`write`): all links in kinematic mode, the rest in dynamic mode
        self.follower_links = [b.links[0].name for b in bodies if b.frame == 0]

        plan = scenery
        own_world = world is None
        if plan is not None:
            limits = plan.layout_limits(len(bodies))
            limits["max_renderables_per_env"] += 2 if needle else 0  # the needle and its thread
            world = cressim.World(cressim.SceneLayout(num_envs, **limits))
        elif own_world:
            world = cressim.World(cressim.SceneLayout(num_envs))
        scenery = None
        if plan is not None:  # what surrounds the arm (cameras, lights, props), from the caller's plan
            visuals = ArmVisuals(urdf, Path(urdf_path).parent, bodies, poses)
            scenery = plan.build(world, visuals)
        self.scenery = scenery
        self.needle_pose0 = None  # the held needle's arc frame in the world at the authored joints:
        self.authored_q = q_author  # the initial ones (kinematic), zeros (dynamic: posed by the engine's reset)
        if needle:
            k, centre, frame, in_body = self._needle_frame(needle, bodies, poses)
            local = np.eye(4)
            local[:3, :3], local[:3, 3] = frame, centre
            self.needle_pose0 = bodies[k].pose @ local
            self.needle_holder = k  # the body whose jaws hold it
            thread_way = bodies[k].pose[:3, :3] @ -in_body[:3, 1]  # back along the jaws
            # its own body (origin at its centre of mass: the engine's), drawn with the jaws' segmentation id
            mass, inertia, self._needle_frame_in_arc = needle_body(needle["arc_radius"], needle["arc_angle"], NEEDLE_WIRE)
            self.needle_mass = (mass, inertia)  # kg, kg m^2 (principal, about its centre of mass)
            arc_in_body = np.linalg.inv(self._needle_frame_in_arc)
            pts, tris, normals = needle_arrays(needle["arc_radius"], needle["arc_angle"], NEEDLE_WIRE)
            pts = pts @ arc_in_body[:3, :3].T.astype(np.float32) + arc_in_body[:3, 3].astype(np.float32)
            normals = normals @ arc_in_body[:3, :3].T.astype(np.float32)
            needle_drawn = (world.add_mesh(cressim.Mesh(pts, tris, normals)), k + 1)
        needle_ids = np.zeros(num_envs, dtype=np.int64)
        body_ids = np.zeros((num_envs, len(bodies)), dtype=np.int64)
        joint_ids = np.zeros((num_envs, len(joint_specs)), dtype=np.int64)
        for env in range(num_envs):
            entities = []
            for k, b in enumerate(bodies):
                e = world.create_entity(env=env, name=b.name)
                e.add(cressim.Transform(position=tuple(float(v) for v in b.pose[:3, 3]),
                                        rotation=rotation_xyzw(b.pose[:3, :3])))
                if b.frame == 0:
                    e.add(cressim.RigidBody(mass=0.1, kinematic=True))
                else:
                    e.add(cressim.RigidBody(mass=b.mass, inertia=b.inertia))
                shapes = [s for link in b.links
                          for s in _link_shapes(link, np.linalg.solve(b.pose, poses[link.name]))]
                if shapes:
                    e.add(cressim.Collider(shapes, group=collision_group, mask=0xFFFFFFFF & ~collision_group))
                if scenery is not None:
                    scenery.add_body_visual(e, k)
                entities.append(e)
                body_ids[env, k] = e.id
            if scenery is not None:
                scenery.add_env(world, env)
            if needle:
                needle_ids[env] = self._add_needle(world, env, needle, self.needle_pose0, thread_way,
                                                   needle_drawn if scenery else None, self._needle_frame_in_arc,
                                                   self.needle_mass, collision_group)
            for k, spec in enumerate(joint_specs):
                parent = None if spec["parent"] is None else entities[spec["parent"]]
                e = world.create_entity(env=env, name=spec["name"])
                e.add(cressim.Joint(spec["kind"], body_a=parent, body_b=entities[spec["child"]],
                                    anchor=spec["anchor"], axis=spec["axis"], limits=spec["limits"],
                                    drive="position", stiffness=spec["drive"][0], damping=spec["drive"][1],
                                    max_force=spec["drive"][2]))
                joint_ids[env, k] = e.id
        self.body_names = [b.name for b in bodies]
        self._body_frames = {link.name: (k, np.linalg.solve(b.pose, poses[link.name])) for k, b in enumerate(bodies)
                             for link in b.links}
        self.body_entity_ids = body_ids  # (N, B): the entity of each body in each env
        self.needle_entity_ids = needle_ids if needle else None  # (N,): each env's needle body
        body_of_link = {link.name: k for k, b in enumerate(bodies) for link in b.links}
        self.link_entity_ids = body_ids[:, [body_of_link[n] for n in self.link_names]]  # (N, L)
        self.joint_names = [spec["name"] for spec in joint_specs]
        self.joint_entity_ids = joint_ids

        self.simulated = plan is not None and plan.simulated()  # a world that moves by itself (particles)
        self.has_fluid = plan is not None and plan.has_fluid()
        self.has_heat = plan is not None and plan.has_heat()
        self.dt = 1.0 / publish_rate
        self._authored = (bodies, joint_specs, initial_q, initial_jaw)
        self.engine = None
        if not own_world:
            return  # the caller's engine: bind(engine)
        engine = cressim.Engine(world, device=device)
        substeps = int(round(physics_rate / publish_rate))
        engine.physics = cressim.PhysicsSettings(dt=1.0 / publish_rate, substeps=substeps,
                                                 particle_substeps=int(round(particle_rate / publish_rate)),
                                                 iterations=SOLVER_ITERATIONS if self.dynamic else 1,
                                                 gravity=tuple(float(g) for g in self.gravity),
                                                 **(plan.physics_settings() if plan is not None else {}))
        engine.prepare()
        engine.upload_world()
        self.bind(engine, cuda_stream=True)

    @staticmethod
    def _needle_frame(spec, bodies, poses):
        """Where a needle held between the jaws sits: (the body that carries the jaw link, the arc's
        centre and frame in that body's frame, the jaw link's frame there). Its arc lies across
        the jaws (normal to their length, the link's +y) through the grasp point, held a third of
        the way from its tail with its tangent along the link's z."""
        k = next(i for i, b in enumerate(bodies) if any(link.name == JAW_LINK for link in b.links))
        in_body = np.linalg.solve(bodies[k].pose, poses[JAW_LINK])
        R, held = spec["arc_radius"], spec["arc_angle"] / 3
        r, t = in_body[:3, 0], in_body[:3, 2]  # the link's x (out from the centre) and z (the tangent there)
        x_a = math.cos(held) * r - math.sin(held) * t
        y_a = math.sin(held) * r + math.cos(held) * t
        frame = np.stack([x_a, y_a, np.cross(x_a, y_a)], 1)
        centre = (in_body @ np.append(JAW_GRASP_POINT, 1.0))[:3] - R * r
        return k, centre, frame, in_body

    @staticmethod
    def _add_needle(world, env, spec, pose, thread_way, drawn, frame_in_arc, mass, arm_group) -> int:
        """The needle (cressim.Needle on a body of its own, its arc frame at `pose`: kinematic while
        the jaws carry it, dynamic once they let it go: TwinArms) and its thread, a 2-0 braid in 2 mm
        segments trailing from the tail along `thread_way`. The body (a steel wire of NEEDLE_WIRE
        bent on the arc: `mass`, `frame_in_arc`) collides through capsules along the arc with the
        world's rigid shapes, but neither with the arm (`arm_group`) nor with particles (its tip
        alone acts on tissue). Returns the needle body's entity id."""
        R, A = spec["arc_radius"], spec["arc_angle"]
        arc_in_body = np.linalg.inv(frame_in_arc)
        tail = pose[:3, 3] + R * pose[:3, 0]
        count = int(round(spec["thread_length"] / 0.002)) + 1
        pts = tail + np.linspace(0.0, spec["thread_length"], count)[:, None] * thread_way
        thread = world.create_entity(env=env, name="suture_thread")
        thread.add(cressim.Strand(pts.astype(np.float32), radius=0.00015, youngs_modulus=5e7, poisson_ratio=0.4,
                                  density=1140, damping=2.0))
        thread.add(cressim.Material(color=(0.25, 0.2, 0.7, 1), roughness=0.6))
        body = world.create_entity(env=env, name="suture_needle")
        at = pose @ frame_in_arc
        body.add(cressim.Transform(position=tuple(float(v) for v in at[:3, 3]), rotation=rotation_xyzw(at[:3, :3])))
        body.add(cressim.RigidBody(kinematic=True, mass=float(mass[0]), inertia=tuple(float(v) for v in mass[1])))
        phi = np.linspace(0.0, A, NEEDLE_SEGMENTS + 1)
        ends = (arc_in_body[:3, :3] @ np.stack([R * np.cos(phi), R * np.sin(phi), np.zeros_like(phi)])).T + arc_in_body[:3, 3]
        shapes = []
        for a, b in zip(ends[:-1], ends[1:]):
            z = (b - a) / np.linalg.norm(b - a)
            x = np.cross(z, [0.0, 0.0, 1.0] if abs(z[2]) < 0.9 else [1.0, 0.0, 0.0])
            x /= np.linalg.norm(x)
            shapes.append(cressim.Shape.capsule(NEEDLE_WIRE, float(np.linalg.norm(b - a) / 2),
                                                position=tuple(float(v) for v in (a + b) / 2),
                                                rotation=rotation_xyzw(np.stack([x, np.cross(z, x), z], 1))))
        body.add(cressim.Collider(shapes, group=1 | COLLIDER_NO_PARTICLES, mask=0xFFFFFFFF & ~arm_group))
        body.add(cressim.Needle(thread=thread, arc_radius=R, arc_angle=A, puncture_force=spec["puncture_force"],
                                puncture_depth=spec["puncture_depth"], friction=spec["friction"],
                                squeeze=spec.get("squeeze", 0.0), center=tuple(float(v) for v in arc_in_body[:3, 3]),
                                rotation=rotation_xyzw(arc_in_body[:3, :3])))
        if drawn is not None:
            mesh, label = drawn
            body.add(cressim.Renderable(mesh, color=(0.75, 0.75, 0.78, 1.0), metallic=0.9, roughness=0.3,
                                        segmentation_id=label))
        return body.id

    def bind(self, engine: cressim.Engine, *, cuda_stream: bool = False):
        """Binds the arm to the engine of its world (prepared and uploaded): body and joint rows,
        target buffers; a dynamic arm is posed at its initial joint values. `cuda_stream`: make the
        engine's frames wait for torch's current stream (an engine the caller owns sets its own)."""
        if self.engine is not None:
            raise RuntimeError("ArmBodies.bind: the arm is bound to an engine already")
        bodies, joint_specs, initial_q, initial_jaw = self._authored
        body_ids, joint_ids, num_envs = self.body_entity_ids, self.joint_entity_ids, self.num_envs
        self.engine = engine
        self.target_positions = torch.from_dlpack(self.engine.buffer("control.body_target_positions"))
        self.target_rotations = torch.from_dlpack(self.engine.buffer("control.body_target_rotations"))
        self.device = self.target_positions.device
        if cuda_stream and self.device.type == "cuda":  # frames wait for targets written on torch's stream
            self.engine.set_cuda_stream(torch.cuda.current_stream(self.device).cuda_stream)
        body_entity = np.asarray(self.engine.buffer("rigid.body_entity").read()).astype(np.int64)
        row_of_entity = {int(e): row for row, e in enumerate(body_entity)}
        follower = [k for k, b in enumerate(bodies) if b.frame == 0]
        follower_rows = np.vectorize(row_of_entity.get, otypes=[np.int64])(body_ids[:, follower])
        # the followers' poses: FK on the GPU from `joint_values` (arm joints, then the jaw)
        self.link_poses = LinkPoses(engine, self.chain, self.follower_links, follower_rows.reshape(num_envs, -1),
                                    self.base[:3, 3].tolist(), rotation_xyzw(self.base[:3, :3].numpy()),
                                    name=self.name)
        self.joint_values = torch.from_dlpack(self.link_poses.joint_values)  # (N, dof + 1) float32
        self.body_rows = torch.as_tensor(np.vectorize(row_of_entity.get)(body_ids), device=self.device,
                                         dtype=torch.long).reshape(num_envs, len(bodies))
        self.needle_rows = None if self.needle_entity_ids is None else torch.as_tensor(
            np.vectorize(row_of_entity.get)(self.needle_entity_ids), device=self.device, dtype=torch.long)
        if self.needle_rows is not None:  # which needle of particles.needles is each env's, and who holds it
            needle_bodies = np.asarray(engine.buffer("particles.needles").read())[:, 0].astype(np.int64)
            index = {int(b): k for k, b in enumerate(needle_bodies)}
            self._needle_index = torch.as_tensor([index[int(r)] for r in self.needle_rows.cpu()], device=self.device)
            # uint32 buffers, written as int32 (torch fills no uint32)
            self._needle_kinematic = torch.from_dlpack(engine.buffer("control.body_kinematic")).view(torch.int32)
            self._needle_holders = torch.from_dlpack(engine.buffer("control.needle_holders")).view(torch.int32)
            self.hold_needle(torch.arange(num_envs), True)
        self.health = torch.from_dlpack(self.engine.buffer("env.health"))
        self.reset_velocities = torch.from_dlpack(self.engine.buffer("control.body_reset_velocities"))
        self.reset_angular_velocities = torch.from_dlpack(
            self.engine.buffer("control.body_reset_angular_velocities"))
        # the arm's kinematics and drive controller run on the CPU: (N, J) rows and small chains
        # cost a GPU more in kernel launches and syncs than in math; only the engine's buffers
        # (targets in, joint values out) live on its device, one copy each way per frame
        self._on = dict(device=torch.device("cpu"), dtype=torch.float64)
        self.base = self.base.to(**self._on)
        if self.dynamic:
            self._init_dynamic(bodies, joint_specs, joint_ids, initial_q, initial_jaw)

    # ------------------------------------------------------------------ authoring (dynamic)
    def _plan_dynamic(self, urdf, joints, poses):
        """Bodies (kinematic followers and the chain's dynamic bodies) and joints of the dynamic arm."""
        dof = self.dof
        links = {link.name: link for link in urdf.robot.links}
        ref, axes = self._serial_chain(urdf)
        # which body each link rides on: its pose relative to that body's reference link is constant
        # over random joint values (the highest such body; 0 is the base)
        gen = torch.Generator().manual_seed(0)
        samples = 8
        lower, upper = torch.as_tensor(self.chain.lower[:dof]), torch.as_tensor(self.chain.upper[:dof])
        q = lower + (upper - lower) * torch.rand(samples, dof, generator=gen, dtype=torch.float64)
        jaw = torch.rand(samples, 1, generator=gen, dtype=torch.float64)
        sampled = self._fk_links(q, jaw, all_links=True, with_base=False)
        eye = torch.eye(4, dtype=torch.float64).expand(samples, 4, 4)
        frames = torch.stack([eye] + [sampled[name] for name in ref], dim=1)  # (S, dof + 1, 4, 4)
        frame_of = {}
        for name, T in sampled.items():
            for k in range(dof, -1, -1):
                rel = torch.linalg.solve(frames[:, k], T)
                if float((rel - rel[0]).abs().max()) < RIGID_TOLERANCE:
                    frame_of[name] = k
                    break
        # the jaw blades: joints hung off the way to the tip and driven by the jaw, hinges on the
        # body of their parent link at multiplier x jaw
        way = set(self._way)
        blades = []
        for j in urdf.robot.joints:
            mimic = j.mimic
            source = mimic.joint if mimic is not None else j.name
            if (j.type in ("revolute", "continuous") and source == JAW and j.child not in way
                    and _link_shapes(links[j.child])):
                blades.append(j)

        base = self.base.numpy()
        ref0 = [base] + [poses[name] for name in ref]  # reference links at q = 0, in the world
        bodies = []
        for name in self.link_names:  # kinematic followers: the mount (frame 0) and the parallelogram bars
            if frame_of.get(name) in (None, 0) and all(b.child != name for b in blades):
                b = _Body(name, 0)
                b.links, b.pose = [links[name]], poses[name]
                bodies.append(b)
        # body origins: where the joints meet on the body's own axis (see _mass_properties): for a
        # hinge the point of its axis nearest the next hinge's (the previous one's when the next
        # slides or is missing): the RCM for the PSM's yaw and pitch; for a slider the next hinge's
        # (the PSM's instrument wrist, on the insertion axis)
        world_axes = [(base[:3, :3] @ a, base[:3, :3] @ p + base[:3, 3], kind) for a, p, kind in axes]
        origin = {k: _meeting_point(world_axes, k - 1, ref0[k][:3, 3]) for k in range(1, dof + 1)}
        for k in range(dof, 0, -1):  # a slider's body: at the next hinge's origin
            if world_axes[k - 1][2] == PRISMATIC and k < dof and world_axes[k][2] == REVOLUTE:
                origin[k] = origin[k + 1]
        segment = {}
        for k in range(1, dof + 1):
            members = [links[n] for n in self.link_names if frame_of.get(n) == k]
            b = _Body(members[0].name if members else f"{self.name}_{self.joints[k - 1]}_body", k)
            b.links = members
            prismatic = world_axes[k - 1][2] == PRISMATIC
            self._mass_properties(b, poses, _frame_along(ref0[k], world_axes[k - 1][0]), origin[k],
                                  0.0 if prismatic else ARMATURE.get(self.joints[k - 1], 0.0))
            segment[k] = len(bodies)
            bodies.append(b)
        joint_specs = []
        for k in range(1, dof + 1):
            name, kind = self.joints[k - 1], world_axes[k - 1][2]
            lo, hi = float(self.chain.lower[k - 1]), float(self.chain.upper[k - 1])
            if not (np.isfinite(lo) and np.isfinite(hi)):
                raise ValueError(f"dynamic arm: joint {name} needs limits in the URDF")
            joint_specs.append(dict(
                name=name, kind="hinge" if kind == REVOLUTE else "slider",
                parent=None if k == 1 else segment[k - 1], child=segment[k],
                anchor=tuple(float(v) for v in origin[k]), axis=tuple(float(v) for v in world_axes[k - 1][0]),
                limits=(lo, hi), drive=_drive(name, kind, joints[name]), gain=1.0, frame=k,
                speed=float(joints[name].limit.velocity)))
        for j in blades:
            parent = frame_of.get(j.parent)
            if parent is None or parent < 1:
                raise ValueError(f"jaw blade joint {j.name}: its parent link {j.parent} rides on no body")
            b = _Body(j.child, f"jaw:{j.name}")
            b.links = [links[j.child]]
            T = poses[j.child]  # the blade's joint frame at jaw = 0
            axis = T[:3, :3] @ np.asarray(j.axis if j.axis is not None else (1, 0, 0), dtype=np.float64)
            self._mass_properties(b, poses, T, T[:3, 3], ARMATURE["jaw"])
            bodies.append(b)
            lo, hi = sorted((j.limit.lower, j.limit.upper))
            joint_specs.append(dict(
                name=j.name, kind="hinge", parent=segment[parent], child=len(bodies) - 1,
                anchor=tuple(float(v) for v in T[:3, 3]), axis=tuple(float(v) for v in axis),
                limits=(lo, hi), drive=DRIVES["jaw"], gain=float(j.mimic.multiplier or 1.0) if j.mimic else 1.0,
                frame=parent, speed=float(j.limit.velocity)))
        self._ref_links = ref
        return bodies, joint_specs

    def _serial_chain(self, urdf):
        """The arm joints' serial chain along the URDF's way from the base to the tip link: each
        joint's reference link (the last link it moves on that way) and its axis ((direction, a
        point, type) at q = 0 in the base link), the screw that takes reference link k - 1 to
        reference link k. Raises where the arm joints are not serial along that way, or where a
        joint's links (a linkage of mimic joints) do not turn about, or slide along, one axis."""
        dof, chain = self.dof, self.chain
        parent_joint = {j.child: j for j in urdf.robot.joints}
        way, name = [], self.tip_link
        while name in parent_joint:
            way.append(parent_joint[name])
            name = parent_joint[name].parent
        way.reverse()
        self._way = [name] + [j.child for j in way]
        index = {n: i for i, n in enumerate(chain.joint_names)}
        moving = [index[j.name] for j in way if j.name in index]
        columns = [chain.columns[i] for i in moving]
        if sorted(set(columns)) != list(range(dof)) or columns != sorted(columns):
            raise ValueError(f"dynamic arm: the joints from the base to {self.tip_link} are not the serial chain "
                             f"{', '.join(self.joints)} (they follow {[chain.sources[c] for c in columns]})")
        zero = torch.zeros(1, dof + 1, dtype=torch.float64)
        poses = {n: chain.link_poses(zero)[0, chain.links.index(n)].numpy() for n in self._way}
        ref, axes = [], []
        for k in range(dof):
            mine = [i for i, c in zip(moving, columns) if c == k]
            ref.append(chain.joint_links[mine[-1]])
            # the screw: the sum of each joint's twist at q = 0 (base-link axes), times its gain
            w, v = np.zeros(3), np.zeros(3)
            for i in mine:
                T = poses[chain.joint_links[i]]
                a, p = T[:3, :3] @ chain.axes[i], T[:3, 3]
                if chain.joint_types[i] == REVOLUTE:
                    w += chain.gains[i] * a
                    v += chain.gains[i] * np.cross(p, a)  # -w x p
                else:
                    v += chain.gains[i] * a
            if np.linalg.norm(w) > 1e-9:
                rate, kind = np.linalg.norm(w), REVOLUTE
                direction, point = w / rate, np.cross(w, v) / rate ** 2
            else:
                rate, kind = np.linalg.norm(v), PRISMATIC
                direction, point = v / rate, poses[ref[-1]][:3, 3]
            if abs(rate - 1.0) > 1e-6:
                raise ValueError(f"dynamic arm: joint {self.joints[k]} moves its links at {rate:.6g} x its value")
            axes.append((direction, point, kind))
        self._check_screws(ref, axes)
        return ref, axes

    def _check_screws(self, ref, axes):
        """Each reference link, over random joint values, where the one before and a turn about (or a
        shift along) joint k's axis put it; else the engine's single joint cannot stand for the
        URDF's joints between them."""
        dof = self.dof
        gen = torch.Generator().manual_seed(1)
        lower, upper = torch.as_tensor(self.chain.lower[:dof]), torch.as_tensor(self.chain.upper[:dof])
        q = lower + (upper - lower) * torch.rand(8, dof, generator=gen, dtype=torch.float64)
        values = torch.cat([q, torch.zeros(8, 1, dtype=torch.float64)], 1)
        F = self.chain.link_poses(torch.cat([torch.zeros(1, dof + 1, dtype=torch.float64), values])).numpy()
        index = [self.chain.links.index(n) for n in ref]
        for k in range(dof):
            direction, point, kind = axes[k]
            before0 = np.eye(4) if k == 0 else F[0, index[k - 1]]
            for m in range(1, 9):
                before = np.eye(4) if k == 0 else F[m, index[k - 1]]
                motion = screw_motion(direction, point, kind, float(q[m - 1, k]))
                expected = before @ np.linalg.solve(before0, motion @ F[0, index[k]])
                if np.abs(expected - F[m, index[k]]).max() > 1e-6:
                    raise ValueError(f"dynamic arm: the links joint {self.joints[k]} moves do not turn about "
                                     f"(or slide along) one axis")

    @staticmethod
    def _mass_properties(b: _Body, poses, frame, origin, armature=0.0):
        """Body frame at `origin` (a point on the body's joint axis) with the orientation of `frame`;
        the links' mass; their inertia about that point (diagonal in the body frame).

        The engine takes the body origin for the centre of mass. We put it where the body's
        joints meet on its axis, not at the links' centre of mass: XPBD's hinge constraints
        (one Gauss-Seidel sweep per iteration) converge badly when an anchor sits far along the
        axis from a body whose inertia across the axis is small (a long, light link such as the
        yaw link: 0.41 m from the RCM, 0.009 kg m^2), and the arm then drifted under gravity even
        with rigid drives. With the origin on the joints the inertia about each joint axis is
        still the links' (parallel-axis term included), so each joint's own dynamics are right;
        what changes is where gravity acts (at the joints, as in a counterbalanced arm; the
        gravity feed-forward models exactly that) and the coupling between joints."""
        parts = []
        for link in b.links:
            inertial = link.inertial
            if inertial is None or not inertial.mass:
                continue
            T = poses[link.name] @ (inertial.origin if inertial.origin is not None else np.eye(4))
            parts.append((float(inertial.mass), T, np.asarray(inertial.inertia, dtype=np.float64)))
        pose = np.array(frame, dtype=np.float64)
        pose[:3, 3] = origin
        mass = sum(m for m, _, _ in parts)
        inertia = np.zeros((3, 3))
        for m, T, I in parts:
            r = T[:3, 3] - pose[:3, 3]
            inertia += T[:3, :3] @ I @ T[:3, :3].T + m * (r @ r * np.eye(3) - np.outer(r, r))
        R = pose[:3, :3]
        b.pose, b.mass = pose, max(mass, MIN_MASS)
        diag = np.diag(R.T @ inertia @ R) + np.array([0.0, 0.0, armature])  # z: the joint axis
        b.inertia = tuple(float(max(v, MIN_INERTIA)) for v in diag)

    def _init_dynamic(self, bodies, joint_specs, joint_ids, initial_q, initial_jaw):
        N, dev = self.num_envs, self._on["device"]
        joint_entity = np.asarray(self.engine.buffer("joint.entity").read()).astype(np.int64)
        row_of_entity = {int(e): row for row, e in enumerate(joint_entity)}
        # joint_rows[env, k]: the row in joint.* / control.joint_* of joint k (dof arm joints, then blades)
        self.joint_rows = torch.as_tensor(np.vectorize(row_of_entity.get)(joint_ids), device=self.device,
                                          dtype=torch.long).reshape(N, len(joint_specs))
        self._flat_rows = self.joint_rows.reshape(-1)
        self.joint_positions = torch.from_dlpack(self.engine.buffer("joint.positions"))
        self.joint_velocities = torch.from_dlpack(self.engine.buffer("joint.velocities"))
        self.joint_targets = torch.from_dlpack(self.engine.buffer("control.joint_targets"))
        self.joint_reset = torch.from_dlpack(self.engine.buffer("control.joint_reset"))
        self.stiffness = torch.tensor([s["drive"][0] for s in joint_specs], **self._on)
        self.max_force = torch.tensor([s["drive"][2] for s in joint_specs], **self._on)
        self._d_over_k = torch.tensor([s["drive"][1] / s["drive"][0] for s in joint_specs], **self._on)
        self._twin_d_over_k = torch.tensor([TWIN_DAMPING.get(s["name"], 0.0) / s["drive"][0] for s in joint_specs],
                                           **self._on)
        self._speed = torch.tensor([s["speed"] for s in joint_specs], **self._on)
        self._lower = torch.tensor([s["limits"][0] for s in joint_specs], **self._on)
        self._upper = torch.tensor([s["limits"][1] for s in joint_specs], **self._on)
        gains = torch.tensor([s["gain"] for s in joint_specs[self.dof:]], **self._on)
        self.blade_gains = gains  # (J - dof,)
        # joint values (N, dof + 1: arm then jaw) -> coordinates of every engine joint (N, J)
        J = len(joint_specs)
        to_coord = torch.zeros(self.dof + 1, J, **self._on)
        to_coord[: self.dof, : self.dof] = torch.eye(self.dof, **self._on)
        to_coord[self.dof, self.dof:] = gains
        self._to_coord = to_coord
        # coordinates (N, J) -> jaw: the mean over blades of coordinate / gain
        self._jaw_of = (1.0 / gains / max(len(gains), 1))[:, None] if len(gains) else None
        # gravity model: mass and centre of mass (the body origin) of each dynamic body, and each arm
        # joint's axis and anchor, in the frame of the reference link they move with
        dyn = [b for b in bodies if b.frame != 0]
        frame_index = {s["child"]: s["frame"] for s in joint_specs}  # blades: their parent's frame
        body_index = {id(b): k for k, b in enumerate(bodies)}
        self._ref_chain = Chain(self.urdf, sources=self.chain.sources, links=self._ref_links)
        zero = torch.zeros(1, self.dof + 1, dtype=torch.float64)
        ref0 = self.base.cpu().numpy() @ np.concatenate([np.eye(4)[None], self._ref_chain.link_poses(zero)[0].numpy()])
        seg, mass, com = [], [], []
        for b in dyn:
            k = frame_index[body_index[id(b)]]
            seg.append(k)
            mass.append(b.mass)
            com.append(np.linalg.solve(ref0[k], np.append(b.pose[:3, 3], 1.0))[:3])
        seg = torch.tensor(seg, device=dev)
        self._g_seg = seg
        self._g_force = torch.tensor(np.outer(mass, self.gravity), **self._on)  # (B, 3)
        self._g_com = torch.tensor(np.array(com), **self._on)  # (B, 3) in the body's reference frame
        arm = joint_specs[: self.dof]
        axes = [ref0[k + 1][:3, :3].T @ np.asarray(s["axis"]) for k, s in enumerate(arm)]
        self._g_axis = torch.tensor(np.array(axes), **self._on)  # (dof, 3)
        self._g_anchor = torch.tensor(np.array([np.linalg.solve(ref0[k + 1], np.append(s["anchor"], 1.0))[:3]
                                                for k, s in enumerate(arm)]), **self._on)
        # carried[i, b]: arm joint i (0-based) moves body b
        self._g_carried = (seg[None, :] >= torch.arange(1, self.dof + 1, device=dev)[:, None]).to(torch.float64)
        self._prismatic = torch.tensor([s["kind"] == "slider" for s in arm], device=dev)
        # start: every env posed at the initial joint values by the engine's reset
        q0 = torch.as_tensor(np.asarray(initial_q, dtype=np.float64)[None, : self.dof], **self._on).repeat(N, 1)
        jaw0 = torch.full((N, 1), float(initial_jaw), **self._on)
        self._hinge = torch.tensor([s["kind"] == "hinge" for s in joint_specs], device=dev)
        self._coords = self.coordinates(q0, jaw0)  # measured coordinates (unwrapped) after the last frame
        self._rates = torch.zeros_like(self._coords)
        self._bias = torch.zeros(N, J, **self._on)  # integral terms (coordinates)
        self._bias_limit = INTEGRAL_LIMIT * self.max_force / self.stiffness
        self._last_coords = self.coordinates(q0, jaw0)
        self.set_targets(q0, jaw0)
        self.prepare_reset(torch.arange(N, device=dev), q0, jaw0)
        self.engine.reset_envs(list(range(N)))

    # ------------------------------------------------------------------ kinematics
    def _values(self, q, jaw):
        return torch.cat([q[:, : self.dof].to(**self._on), jaw.to(**self._on)], dim=-1)

    def _fk_links(self, q, jaw, *, all_links=False, with_base=True):
        """(M, dof), (M, 1) float64 -> {link: (M, 4, 4)} (numpy (4, 4) for M = 1 unless all_links)."""
        F = self.chain.link_poses(torch.cat([q[:, : self.dof], jaw], dim=-1))  # (M, L, 4, 4)
        if with_base:
            F = self.base.to(q) @ F
        if all_links:
            return {name: F[:, k] for k, name in enumerate(self.chain.links)}
        return {name: F[0, k].cpu().numpy() for k, name in enumerate(self.chain.links)}

    def urdf_joints(self, q: torch.Tensor, jaw: torch.Tensor) -> tuple[list[str], torch.Tensor]:
        """Every moving URDF joint's name and value ((M, J)), mimic joints included: what
        robot_state_publisher reads from /joint_states."""
        return list(self.chain.joint_names), self.chain.values(self._values(q, jaw))

    def link_transforms(self, q: torch.Tensor, jaw: torch.Tensor) -> tuple[list[tuple[str, str]], torch.Tensor]:
        """[(parent link, child link)] of every URDF joint and (M, J, 4, 4) child in parent:
        the transforms robot_state_publisher puts on /tf."""
        F = self.chain.link_poses(self._values(q, jaw))
        index = {name: k for k, name in enumerate(self.chain.links)}
        pairs = [(j.parent, j.child) for j in self.urdf.robot.joints if j.parent in index and j.child in index]
        parent = F[:, [index[a] for a, _ in pairs]]
        child = F[:, [index[b] for _, b in pairs]]
        return pairs, torch.linalg.solve(parent, child)

    # ------------------------------------------------------------------ per tick
    def write(self, q: torch.Tensor, jaw: torch.Tensor):
        """Poses the kinematic bodies (all links; dynamic mode: the followers) at joint values
        q (N, >= dof) and jaw (N, 1): one copy into `joint_values` and the GPU's FK pass,
        recorded in the current frame (before step_physics)."""
        self.joint_values[:, : self.dof] = q[:, : self.dof].to(self.joint_values)
        self.joint_values[:, self.dof:] = jaw.to(self.joint_values)
        self.link_poses.execute()

    def pose(self):
        """Records the FK pass on `joint_values` as they are (a task pass wrote them)."""
        self.link_poses.execute()

    def gravity_torques(self, q: torch.Tensor) -> torch.Tensor:
        """(M, >= dof) -> (M, dof): generalized gravity force on each arm joint (N m or N) from the
        dynamic bodies it carries (jaw blades counted as rigid on the wrist)."""
        q = q[:, : self.dof].to(**self._on)
        F = self.base @ self._ref_chain.link_poses(torch.cat([q, torch.zeros_like(q[:, :1])], 1))  # (M, dof, 4, 4)
        frames = torch.cat([self.base.expand(q.shape[0], 1, 4, 4), F], dim=1)
        z = (F[..., :3, :3] @ self._g_axis[..., None])[..., 0]  # joint axes and anchors (M, dof, 3)
        o = (F[..., :3, :3] @ self._g_anchor[..., None])[..., 0] + F[..., :3, 3]
        Tb = frames[:, self._g_seg]  # (M, B, 4, 4)
        com = (Tb[..., :3, :3] @ self._g_com[None, :, :, None]).squeeze(-1) + Tb[..., :3, 3]  # (M, B, 3)
        moments = torch.linalg.cross(com, self._g_force.expand_as(com), dim=-1)  # (M, B, 3)
        m_sum = self._g_carried @ moments  # (M, dof, 3)
        f_sum = self._g_carried @ self._g_force  # (dof, 3)
        revolute = ((m_sum - torch.linalg.cross(o, f_sum.expand_as(o), dim=-1)) * z).sum(-1)
        prismatic = (f_sum[None] * z).sum(-1)
        return torch.where(self._prismatic[None], prismatic, revolute)

    def coordinates(self, q: torch.Tensor, jaw: torch.Tensor) -> torch.Tensor:
        """Interface values (N, >= dof), (N, 1) -> engine joint coordinates (N, J)."""
        return torch.cat([q[:, : self.dof].to(**self._on), jaw.to(**self._on)], dim=1) @ self._to_coord

    def set_targets(self, q: torch.Tensor, jaw: torch.Tensor, envs: torch.Tensor | None = None):
        """Dynamic mode: drive targets of every env (or of `envs`, a long tensor) for the setpoint
        joint values q (M, >= dof) and jaw (M, 1). Per joint coordinate:

        - the commanded value moves toward the setpoint at most at the URDF velocity limit per
          frame (a servo_jp step becomes a ramp; unramped, the light wrist overshot its limits);
        - + the integral term, for joints whose command did not move since the last frame
          (error = command - measured of the last frame; gain dt / INTEGRAL_TIME, bounded to
          +-INTEGRAL_LIMIT x max force / stiffness). XPBD's drives, solved by Gauss-Seidel with
          the chain's other constraints, are softer than their nominal stiffness (the parent body
          takes part of each correction), so the gravity feed-forward alone leaves ~0.3 mm of
          sag on the insertion; the integral term removes what remains at rest, as a PID would;
        - + damping x command velocity / stiffness: cancels the engine drive's damping toward rest
          while moving (velocity feed-forward);
        - + TWIN_DAMPING x (command velocity - measured velocity) / stiffness on yaw and pitch;
        - - Q_g(q) / stiffness on the arm joints (gravity feed-forward);
        - clamped to the joint limits, and for hinges to within MAX_HINGE_STEP of the measured
          angle (the engine turns a hinge by the wrapped error, and yaw and roll span more than pi).
        """
        idx = slice(None) if envs is None else torch.as_tensor(envs).cpu()
        rows = self.joint_rows[idx if envs is None else idx.to(self.device)]
        last = self._last_coords[idx]
        step = self._speed * self.dt
        coords = last + torch.minimum(torch.maximum(self.coordinates(q, jaw) - last, -step), step)
        velocity = (coords - last) / self.dt
        measured = self._coords[idx]
        rest = (coords == last) & torch.isfinite(measured)
        bias = self._bias[idx]
        bias = torch.where(rest, torch.minimum(torch.maximum(
            bias + (self.dt / INTEGRAL_TIME) * (coords - measured), -self._bias_limit), self._bias_limit), bias)
        self._bias[idx], self._last_coords[idx] = bias, coords
        v_meas = torch.nan_to_num(self._rates[idx], nan=0.0, posinf=0.0, neginf=0.0)
        target = coords + bias + velocity * self._d_over_k + (velocity - v_meas) * self._twin_d_over_k
        target[:, : self.dof] -= self.gravity_torques(q) / self.stiffness[: self.dof]
        target = torch.minimum(torch.maximum(target, self._lower), self._upper)
        here = torch.where(torch.isfinite(measured), measured, coords)
        target = torch.where(self._hinge, here + (target - here).clamp(-MAX_HINGE_STEP, MAX_HINGE_STEP), target)
        self.joint_targets[rows.reshape(-1), 0] = target.reshape(-1).to(self.joint_targets)

    def hold_needle(self, envs: torch.Tensor, held: bool):
        """The needles of `envs` (long tensor) held by the jaws (kinematic, carried by place_needle,
        their load borne by the jaws' body) or let go of (dynamic: they fall, held by the tissue
        they are threaded through), from the next frame on."""
        on = envs.to(self.device)
        rows = self.needle_rows[on]
        self._needle_kinematic[rows.to(self._needle_kinematic.device)] = 1 if held else 0
        holders = (self.body_rows[on, self.needle_holder] + 1) if held else torch.zeros_like(rows)
        self._needle_holders[self._needle_index[on].to(self._needle_holders.device)] = holders.to(self._needle_holders)

    def _needle_body_poses(self, poses: torch.Tensor) -> torch.Tensor:
        """Arc frames (M, 4, 4) -> the needle bodies' poses (float64)."""
        return poses.to(torch.float64) @ torch.as_tensor(self._needle_frame_in_arc).to(poses.device)

    def place_needle(self, envs: torch.Tensor, poses: torch.Tensor):
        """Where the needles of `envs` (long tensor) go over the next frame: poses (M, 4, 4) of their
        arc frames in the world (kinematic targets)."""
        rows = self.needle_rows[envs.to(self.device)]
        p7 = matrix_to_pose7(self._needle_body_poses(poses))
        self.target_positions[rows, :3] = p7[:, :3].to(self.target_positions)
        self.target_rotations[rows] = p7[:, 3:].to(self.target_rotations)

    def set_needle_pose(self, envs: torch.Tensor, poses: torch.Tensor):
        """The needles of `envs` at poses (M, 4, 4) of their arc frames now, at rest: their bodies
        moved there (kinematic ones are held there)."""
        self.place_needle(envs, poses)
        rows = self.needle_rows[envs.to(self.device)]
        p7 = matrix_to_pose7(self._needle_body_poses(poses))
        positions = torch.from_dlpack(self.engine.buffer("rigid.positions"))
        rotations = torch.from_dlpack(self.engine.buffer("rigid.rotations"))
        positions[rows.to(positions.device), :3] = p7[:, :3].to(positions)
        rotations[rows.to(rotations.device)] = p7[:, 3:].to(rotations)
        for key in ("rigid.linear_velocities", "rigid.angular_velocities"):
            v = torch.from_dlpack(self.engine.buffer(key))
            v[rows.to(v.device)] = 0

    def needle_poses(self, envs: torch.Tensor | None = None) -> torch.Tensor:
        """(M, 4, 4) float64 on the CPU: the needle arc frames of `envs` (long tensor; default every
        env) in the world now."""
        rows = self.needle_rows if envs is None else self.needle_rows[envs.to(self.device)]
        p = torch.from_dlpack(self.engine.buffer("rigid.positions"))[rows, :3].to(torch.float64).cpu()
        q = torch.from_dlpack(self.engine.buffer("rigid.rotations"))[rows].to(torch.float64).cpu()
        T = torch.eye(4, dtype=torch.float64).repeat(len(rows), 1, 1)
        T[:, :3, :3] = _quat_matrices(q)
        T[:, :3, 3] = p
        return T @ torch.as_tensor(np.linalg.inv(self._needle_frame_in_arc))

    def show(self, world: cressim.World, envs, links=None, *, first_id: int = 0):
        """Renderables for cameras on a kinematic arm's bodies in `envs`: each named link's URDF
        visuals (ArmVisuals; `links` in this order, default every body), one mesh a link added to
        `world` once. In kinematic mode each body is one link in that link's frame; a dynamic arm
        (the twin's) gets its visuals with its scenery. `first_id` > 0: body k is drawn with
        segmentation id first_id + k (else 0, the background)."""
        from types import SimpleNamespace

        if self.dynamic:
            raise ValueError("ArmBodies.show: a dynamic arm is drawn by its scenery (twin), not show()")
        urdf_links = {link.name: link for link in self.urdf.robot.links}
        for name in self.body_names if links is None else links:
            body = SimpleNamespace(links=[urdf_links[name]], pose=np.eye(4), name=name)
            visuals = ArmVisuals(self.urdf, self.urdf_dir, [body], {name: np.eye(4)})
            m = visuals.meshes[0]
            if m is None:  # a link without visual geometry
                continue
            mesh = world.add_mesh(cressim.Mesh(np.asarray(m.vertices, np.float32), np.asarray(m.faces, np.uint32),
                                               np.asarray(m.vertex_normals, np.float32)))
            k = self.body_names.index(name)
            for env in envs:
                world.entity(int(self.body_entity_ids[env, k])).add(
                    cressim.Renderable(mesh, color=visuals.colors[0], metallic=0.3, roughness=0.4,
                                       segmentation_id=first_id + k if first_id > 0 else 0))

    def link_point(self, link: str, point) -> tuple[np.ndarray, np.ndarray]:
        """Where a point given in `link`'s frame sits on the body that carries the link: (each env's
        entity of that body (N,), the point in the body's frame (3,))."""
        k, frame = self._body_frames[link]
        return self.body_entity_ids[:, k].copy(), (frame @ np.append(np.asarray(point, float), 1.0))[:3]

    def contact_wrench(self, links, point: torch.Tensor) -> torch.Tensor:
        """(N, 6) float64 on the CPU: force (N) and torque (N m) about `point` ((N, 3), world) that
        contacts and held particles exert on the bodies carrying `links`, summed (world axes)."""
        ks = sorted({self._body_frames[name][0] for name in links})
        rows = self.body_rows[:, ks]
        force = torch.from_dlpack(self.engine.buffer("rigid.contact_forces"))[rows, :3]
        torque = torch.from_dlpack(self.engine.buffer("rigid.contact_torques"))[rows, :3]
        origin = torch.from_dlpack(self.engine.buffer("rigid.positions"))[rows, :3]
        force, torque, origin = (t.to(**self._on) for t in (force, torque, origin))
        arm = origin - point.to(**self._on)[:, None, :]
        return torch.cat([force.sum(1), (torque + torch.linalg.cross(arm, force)).sum(1)], dim=1)

    def set_rate(self, dt: float, substeps: int, particle_substeps: int = 0):
        """Frame time (one publish period), substeps of the engine and of its particles (0: the same)."""
        physics = self.engine.physics
        physics.dt, physics.substeps, physics.particle_substeps = dt, substeps, particle_substeps
        self.engine.physics = physics
        self.dt = dt

    def read_joints(self):
        """Dynamic mode: (q (N, dof), qd (N, dof), jaw (N, 1), jaw_d (N, 1)) float64: the engine's
        joint coordinates and rates after the last `step` (NaN where that frame failed)."""
        p, v = self._coords, self._rates
        if self._jaw_of is None:
            zeros = torch.zeros(self.num_envs, 1, **self._on)
            return p[:, : self.dof], v[:, : self.dof], zeros, zeros.clone()
        return p[:, : self.dof], v[:, : self.dof], p[:, self.dof:] @ self._jaw_of, v[:, self.dof:] @ self._jaw_of

    def _gather_joints(self):
        """After a frame: every env's joint coordinates and rates, one gather each. The engine's
        hinge coordinate is an angle in (-pi, pi] (the roll's range is +-4.54 rad): each reading
        is unwrapped against the previous one (a joint turns far less than pi per frame)."""
        both = torch.stack([self.joint_positions[self.joint_rows], self.joint_velocities[self.joint_rows]])
        raw, rates = both.to(torch.float64).cpu()  # one device -> host copy
        prev = self._coords
        turn = raw - prev
        turn = torch.where(self._hinge, torch.remainder(turn + math.pi, 2 * math.pi) - math.pi, turn)
        self._coords = torch.where(torch.isfinite(prev), prev + turn, raw)
        self._rates = rates

    def prepare_reset(self, envs: torch.Tensor, q: torch.Tensor, jaw: torch.Tensor):
        """What the engine's next reset of `envs` does to the arm: joints at q/jaw at rest (dynamic),
        bodies without reset velocities (the twin owns its bodies' reset state)."""
        envs = torch.as_tensor(envs).cpu()
        on_device = envs.to(self.device)
        rows = self.body_rows[on_device].reshape(-1)
        self.reset_velocities[rows] = 0
        self.reset_angular_velocities[rows] = 0
        if self.dynamic:
            jrows = self.joint_rows[on_device].reshape(-1)
            self.joint_reset[jrows, 0] = self.coordinates(q, jaw).reshape(-1).to(self.joint_reset)
            self.joint_reset[jrows, 1] = 0
            self._bias[envs] = 0
            self._coords[envs] = self.coordinates(q, jaw)  # what the reset poses
            self._rates[envs] = 0
            self._last_coords[envs] = self._coords[envs]

    def reset(self, envs: list[int]):
        """The engine resets `envs` at the start of the next frame (what prepare_reset set up)."""
        self.engine.reset_envs(list(envs))

    def step(self, render: bool = False, sense: bool = False):
        """One publish period of physics (the engine runs its substeps), then the cameras when
        `render` and the ultrasound when `sense`, in one submit, waited for."""
        self.engine.step_physics()
        if render:
            self.engine.step_visual_sensors()
        if sense:
            self.engine.step_simulation_sensors()
        self.engine.end_frame()
        if self.dynamic:
            self._gather_joints()

    def health_flags(self) -> torch.Tensor:
        """(N,) int64: the solver's flags of the last frame per env (1 NaN/Inf, 2 speed, 4 penetration)."""
        return self.health.view(torch.int32).to(torch.int64)

    def unhealthy_envs(self) -> list[int]:
        """Envs the solver flagged this frame (NaN, speed, penetration); the engine resets them."""
        bad = self.health.view(torch.int32) != 0
        return torch.nonzero(bad).flatten().tolist() if bool(bad.any()) else []


HEALTH_FLAGS = ((1, "NaN/Inf in the body state"), (2, "a body faster than the solver's max_speed"),
                (4, "penetration deeper than the solver's max_penetration"))


def describe_health(flags: int) -> str:
    names = [text for bit, text in HEALTH_FLAGS if flags & bit]
    return " and ".join(names) if names else f"flags {flags}"


__all__ = ["ARM_GROUP", "DRIVES", "DYNAMICS", "HEALTH_FLAGS", "ArmBodies", "describe_health"]
