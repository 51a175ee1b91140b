"""The twin's sections of a scene file (arm, cart, camera, rates, sensors, num_envs, record,
world; scenes/psm_twin.yaml), read with cressim.config's field reader, so a bad field is
reported as `psm_twin.yaml:12:15: arm.base.position: expected 3 numbers, got 2`. Below the twin
and the tasks, which both read it (a task runs in the twin's world: envs/tissue_retract.py).

The sections sit in a twin file that names its `world:` (an engine scene file), or in an engine
scene file itself beside its entities: one file for a task's world and its twin, which is then
that file's world (cressim.scene_file reads the world's sections and passes over these).
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from cressim.config import Field, FieldError, parse, read_file
from cressim.robots.dvrk import ARM_KINDS
from cressim.scene_file import ENGINE_SECTIONS, TWIN_SECTIONS

SCENE_DIR_ENV = "CRESSIM_SCENE_DIR"  # overrides where scenes/ is (an install outside the repo)
DEFAULT_SCENE = "psm_twin.yaml"
ROBOTS = ("psm_lnd", "psm_suction")
DYNAMICS = ("kinematic", "dynamic")  # arm.dynamics: the arm's links follow the twin, or are simulated
SENSORS = ("joints", "cartesian", "velocity", "wrench", "jacobian", "tf", "clock", "color", "depth", "segmentation", "ultrasound")


CART_ARMS = ARM_KINDS  # what a `cart:` may name, and its kind
ECM_HOME = (0.0, 0.0, 0.05, 0.0)  # rad, m: the endoscope 5 cm in
GRIPPER_LIMITS = (-0.35, 1.2)  # rad: the MTM gripper's range (about -20 to 70 degrees)


@dataclass(frozen=True)
class CartArm:
    """One arm of a patient cart (scene file `cart:`): its dVRK name (also its ROS namespace and
    frame prefix), kind (psm, ecm, mtm), PSM instrument, and where its base (the RCM) is in the
    world (given, or where its setup joints hold it). An MTM has none of these: its base frame is
    the surgeon console's."""
    name: str
    kind: str
    robot: str = "psm_lnd"
    base_position: tuple = (0.0, 0.0, 0.3)
    base_rotation: tuple = (0.0, 0.0, 0.0, 1.0)
    initial_jp: tuple | None = None  # None: the arm section's (PSM) or ECM_HOME
    home_jp: tuple | None = None


@dataclass
class Keyframe:
    """One keyframe of the operator's script (cart.operator), played by cressim.twin.mtm."""
    at: float  # s after the script starts
    hands: dict  # MTM name -> (3,) position (positions and grips are interpolated between keyframes)
    grips: dict
    pedals: dict  # clutch / camera / present -> bool, from this keyframe on


SceneError = FieldError  # the name the twin's callers catch: a bad scene file, `file:line:column: field: why`


@dataclass
class Scene:
    path: str = "<defaults>"
    arm: str = "PSM1"
    robot: str = "psm_lnd"
    dynamics: str = "kinematic"
    base_position: tuple = (0.0, 0.0, 0.3)
    base_rotation: tuple = (0.0, 0.0, 0.0, 1.0)  # xyzw
    initial_jp: tuple = (0.0, 0.0, 0.1, 0.0, 0.0, 0.0)
    initial_jaw: float = 0.0
    home_jp: tuple | None = (0.0, 0.0, 0.12, 0.0, 0.0, 0.0)
    measured_lag: float = 0.005
    velocity_ratio: float = 0.5
    acceleration_ratio: float = 4.0
    stale_command_after: float = 1.0
    num_envs: int = 1
    physics_rate: float = 200.0
    particle_rate: float = 0.0  # the world's particles substep at this rate; 0: physics_rate
    publish_rate: float = 100.0
    tf_rate: float = 50.0
    camera_rate: float = 30.0
    ultrasound_rate: float = 10.0
    camera_width: int = 640
    camera_height: int = 480
    camera_fov_y: float = 60.0  # degrees
    camera_position: tuple = (0.12, -0.12, 0.32)  # m, in the env's world (z up)
    camera_look_at: tuple = (0.0, 0.0, 0.19)
    sensors: tuple = SENSORS
    record: str = ""
    world: str = ""  # an engine scene file (scenes/*.yaml) around the arm; empty: a rigid block
    grasp_reach: float = 0.004  # m: the jaws take the particles this near their middle
    grasp_closed_below: float = 0.25  # rad: the jaws grasp once the measured jaw angle is below this
    suction_radius: float = 0.005  # m: the suction tool removes the fluid this near its tip
    suction_flow_rate: float = 1e-3 / 60  # m^3/s with the valve open (1 L/min): it draws the fluid in
    suction_reach: float = 0.02  # m: the fluid this near the tip is drawn toward it
    cautery_radius: float = 0.005  # m: an energized needle driver heats the tissue this near its jaws' middle
    cautery_power: float = 30.0  # W while the coag pedal is pressed
    cautery_mode: str = "coag"  # coag: heats; cut: also parts the tissue it has coagulated
    # a suture needle held in the needle driver's jaws (arm.needle; None: none): cressim.Needle's
    # arc_radius, arc_angle, puncture_force, puncture_depth, friction and squeeze, and thread_length (m)
    needle: dict | None = None
    cart: tuple = ()  # CartArm of a patient cart (cressim.twin.cart); empty: the one `arm`
    endoscope_baseline: float = 0.005  # m between the ECM's two cameras (cart.ECM.endoscope.baseline)
    operator: tuple = ()  # Keyframe of a scripted surgeon (cart.operator; cressim.twin.mtm plays them)
    lines: dict = field(default_factory=dict, repr=False)  # field -> "file:line:col" (for later checks)


def find_scene(name: str) -> Path:
    """A scene file by path, or by name in scenes/ of the checkout ($CRESSIM_SCENE_DIR wins)."""
    path = Path(name).expanduser()
    if path.is_file():
        return path
    dirs = [Path(os.environ[SCENE_DIR_ENV])] if os.environ.get(SCENE_DIR_ENV) else []
    for start in (Path.cwd().resolve(), Path(__file__).resolve()):
        dirs += [folder / "scenes" for folder in (start, *start.parents)]
    for folder in dirs:
        if (folder / path.name).is_file():
            return folder / path.name
    raise SceneError(f"{name}: scene file not found (as a path, in ${SCENE_DIR_ENV}, or in a scenes/ "
                     f"folder above {Path.cwd()})")


def load_scene(name: str = DEFAULT_SCENE) -> Scene:
    path = find_scene(name)
    return _scene(read_file(path), str(path))


def parse_scene(text: str, path: str = "<string>") -> Scene:
    return _scene(parse(text, path), path)


def _scene(root: Field | None, path: str) -> Scene:
    """The twin's sections of a scene file (its own, or an engine scene's: then that file is the
    twin's world); an empty file is all defaults."""
    scene = Scene(path=path)
    if root is None:
        return scene
    top = root.keys(TWIN_SECTIONS + ENGINE_SECTIONS)
    if "arm" in top:
        _parse_arm(top["arm"], scene)
    if "cart" in top:
        _parse_cart(top["cart"], scene)
    if "num_envs" in top:
        scene.num_envs = top["num_envs"].int(1, 4096)
    if "rates" in top:
        keys = ("physics", "particles", "publish", "tf", "camera", "ultrasound")
        for key, f in top["rates"].keys(keys).items():
            name = "particle_rate" if key == "particles" else f"{key}_rate"
            setattr(scene, name, f.number(0.0 if key == "particles" else 0.1, 10000.0, "Hz"))  # particles 0: as physics
            scene.lines[name] = f.where
    if "camera" in top:
        cam = top["camera"].keys(("width", "height", "fov_y", "position", "look_at"))
        if "width" in cam:
            scene.camera_width = cam["width"].int(1, 8192)
        if "height" in cam:
            scene.camera_height = cam["height"].int(1, 8192)
        if "fov_y" in cam:
            scene.camera_fov_y = cam["fov_y"].number(1.0, 170.0)
        if "position" in cam:
            scene.camera_position = cam["position"].vec(3, "finite")
        if "look_at" in cam:
            scene.camera_look_at = cam["look_at"].vec(3, "finite")
        if math.dist(scene.camera_position, scene.camera_look_at) < 1e-6:
            raise cam.get("look_at", cam.get("position", top["camera"])).fail(
                "the camera looks at its own position; give a point away from camera.position")
    if "sensors" in top:
        scene.sensors = tuple(f.choice(SENSORS) for f in top["sensors"].list())
    if "record" in top:
        scene.record = top["record"].optional(Field.str) or ""
    engine = [k for k in ENGINE_SECTIONS if k in top]
    if engine:  # one file for the task's world and its twin: the file is the world
        if "world" in top and not top["world"].is_null():
            raise top["world"].fail(f"this file is a world itself (it has {', '.join(engine)}); give either "
                                    "world: or the world's sections")
        if "envs" in top:  # the world's envs are the twin's envs
            envs = top["envs"].int(1, 4096)
            if "num_envs" in top and envs != scene.num_envs:
                raise top["envs"].fail(f"{envs} envs, but num_envs is {scene.num_envs}; give one of them")
            scene.num_envs = envs
        scene.world = path
    elif "world" in top and not top["world"].is_null():
        name = top["world"].str()
        try:  # beside the twin's file, or by name in scenes/
            found = Path(path).parent / name if (Path(path).parent / name).is_file() else find_scene(name)
        except SceneError:
            raise top["world"].fail(f"no scene file {name!r} (beside {path} or in scenes/)") from None
        scene.world = str(found)
    # a check across fields, reported at the line of the one to change
    problem = rates_problem(scene.physics_rate, scene.publish_rate, scene.particle_rate)
    if problem:
        name, why = problem
        raise FieldError.at(scene.lines.get(name, path), f"rates.{RATE_KEYS[name]}", why)
    return scene


# arm.needle: cressim.Needle's fields and thread_length: (low, high, default)
NEEDLE = {"arc_radius": (1e-3, 0.05, 0.008), "arc_angle": (0.5, 5.0, 3 * math.pi / 4),
          "puncture_force": (1e-3, 100.0, 1.0), "puncture_depth": (1e-4, 0.02, 0.002),
          "friction": (0.0, 2.0, 0.3), "squeeze": (0.0, 10.0, 0.0), "thread_length": (0.005, 0.5, 0.06)}


def _parse_arm(f: Field, scene: Scene) -> None:
    arm = f.keys(("name", "robot", "dynamics", "base", "initial_jp", "initial_jaw", "home_jp", "measured_lag",
                  "trajectory", "stale_command_after", "grasp", "suction", "cautery", "needle"))
    if "name" in arm:
        scene.arm = ros_name(arm["name"])
    if "robot" in arm:
        scene.robot = arm["robot"].choice(ROBOTS)
    if "dynamics" in arm:
        scene.dynamics = arm["dynamics"].choice(DYNAMICS)
    if "base" in arm:
        base = arm["base"].keys(("position", "rotation"))
        if "position" in base:
            scene.base_position = base["position"].vec(3, "finite")
        if "rotation" in base:
            scene.base_rotation = base["rotation"].rotation()
    if "initial_jp" in arm:
        scene.initial_jp = arm["initial_jp"].vec(6, "finite")
    if "initial_jaw" in arm:
        scene.initial_jaw = arm["initial_jaw"].number()
    if "home_jp" in arm:
        scene.home_jp = arm["home_jp"].optional(lambda g: g.vec(6, "finite"))
    if "measured_lag" in arm:
        scene.measured_lag = arm["measured_lag"].number(0.0, 1.0, "s")
    if "stale_command_after" in arm:
        scene.stale_command_after = arm["stale_command_after"].number(0.0, unit="s")
    if "grasp" in arm:
        grasp = arm["grasp"].keys(("reach", "closed_below"))
        if "reach" in grasp:
            scene.grasp_reach = grasp["reach"].number(1e-4, 0.05, "m")
        if "closed_below" in grasp:
            scene.grasp_closed_below = grasp["closed_below"].number(-0.7, 1.4, "rad")
    if "suction" in arm:
        suction = arm["suction"].keys(("radius", "flow_rate", "reach"))
        if "radius" in suction:
            scene.suction_radius = suction["radius"].number(1e-4, 0.05, "m")
        if "flow_rate" in suction:
            scene.suction_flow_rate = suction["flow_rate"].number(0.0, 1e-3)
        if "reach" in suction:
            scene.suction_reach = suction["reach"].number(1e-4, 0.2, "m")
        if scene.suction_reach < scene.suction_radius:
            raise suction.get("reach", arm["suction"]).fail(
                f"{scene.suction_reach:g} m is less than the radius {scene.suction_radius:g} m")
    if "cautery" in arm:
        cautery = arm["cautery"].keys(("radius", "power", "mode"))
        if "radius" in cautery:
            scene.cautery_radius = cautery["radius"].number(1e-4, 0.02, "m")
        if "power" in cautery:
            scene.cautery_power = cautery["power"].number(0.0, 300.0, "W")
        if "mode" in cautery:
            scene.cautery_mode = cautery["mode"].choice(("coag", "cut"))
    if "needle" in arm:
        needle = arm["needle"].keys(NEEDLE)
        scene.needle = {k: (needle[k].number(lo, hi) if k in needle else default)
                        for k, (lo, hi, default) in NEEDLE.items()}
    if "trajectory" in arm:
        traj = arm["trajectory"].keys(("velocity_ratio", "acceleration_ratio"))
        if "velocity_ratio" in traj:
            scene.velocity_ratio = traj["velocity_ratio"].number(1e-3, 1.0)
        if "acceleration_ratio" in traj:
            scene.acceleration_ratio = traj["acceleration_ratio"].number(1e-3, 1e3)


def ros_name(f: Field) -> str:
    """A ROS name (the arm's namespace and frame prefix)."""
    value = f.str()
    if not value or not (value[0].isalpha() and all(c.isalnum() or c == "_" for c in value)):
        raise f.fail(f"{value!r} is not a valid ROS name (letters, digits, _; a letter first)")
    return value


def _parse_cart(f: Field, scene: Scene) -> None:
    """`cart:` {ECM: {...}, PSM1: {...}, ...}: the arms of a patient cart, each with its base."""
    from cressim.robots.kinematics import rotation_xyzw
    from cressim.robots.suj import suj_base

    cart = f.keys((*CART_ARMS, "operator", "origin"))
    origin = np.eye(4)  # the cart's frame (the setup joints' origin) in the world
    if "origin" in cart:
        position, rotation = _pose(cart["origin"])
        origin[:3, :3], origin[:3, 3] = _quat_matrix(rotation), position
    arms = []
    for name, arm_node in cart.items():
        if name in ("operator", "origin"):
            continue
        kind = CART_ARMS[name]
        keys = (("base", "setup_joints") if kind != "mtm" else ()) \
            + (("robot", "initial_jp", "home_jp") if kind == "psm" else ()) \
            + (("initial_jp", "home_jp", "endoscope") if kind == "ecm" else ())
        fields = arm_node.keys(keys) if not arm_node.is_null() else {}
        values = dict(name=name, kind=kind)
        if "base" in fields and "setup_joints" in fields:
            raise fields["setup_joints"].fail("give either base or setup_joints")
        if "setup_joints" in fields:  # the dVRK Classic SUJ puts the base there (cressim.robots.suj)
            base = origin @ suj_base(name, fields["setup_joints"].vec(6, "finite"))
            values["base_position"] = tuple(float(v) for v in base[:3, 3])
            values["base_rotation"] = rotation_xyzw(base[:3, :3])
        if "base" in fields:  # the base's pose in the world, as given
            values["base_position"], values["base_rotation"] = _pose(fields["base"])
        if "robot" in fields:
            values["robot"] = fields["robot"].choice(ROBOTS)
        dof = 4 if kind == "ecm" else 6
        for key in ("initial_jp", "home_jp"):
            if key in fields:
                values[key] = fields[key].vec(dof, "finite")
        if "endoscope" in fields:
            scope = fields["endoscope"].keys(("baseline",))
            if "baseline" in scope:
                scene.endoscope_baseline = scope["baseline"].number(1e-4, 0.05, "m")
        arms.append(CartArm(**values))
    if not any(a.kind == "ecm" for a in arms) or not any(a.kind == "psm" for a in arms):
        raise f.fail("a cart needs the ECM and at least one PSM")
    scene.cart = tuple(arms)
    if "operator" in cart:
        scene.operator = _parse_operator(cart["operator"], [a.name for a in arms if a.kind == "mtm"])


def _parse_operator(f: Field, mtms) -> tuple:
    """`cart.operator:` a list of keyframes {at: s, clutch/camera/present: bool, MTMx: {position:
    [x, y, z], gripper: rad}}, in time order."""
    if not f.is_list():
        raise f.fail("a list of keyframes {at, clutch, camera, present, MTML, MTMR} expected")
    frames, last = [], -math.inf
    for item in f.list():
        k = item.keys(("at", "clutch", "camera", "present", *mtms))
        if "at" not in k:
            raise item.fail("every keyframe needs `at` (s)")
        at = k["at"].number(0.0, 1e6, "s")
        if at <= last:
            raise k["at"].fail(f"{at:g} s is not after the keyframe before ({last:g} s)")
        last = at
        pedals = {name: k[name].bool() for name in ("clutch", "camera", "present") if name in k}
        hands, grips = {}, {}
        for name in mtms:
            if name in k:
                hand = k[name].keys(("position", "gripper"))
                if "position" in hand:
                    hands[name] = hand["position"].vec(3, "finite")
                if "gripper" in hand:
                    grips[name] = hand["gripper"].number(*GRIPPER_LIMITS, "rad")
        frames.append(Keyframe(at, hands, grips, pedals))
    return tuple(frames)


def _pose(f: Field) -> tuple:
    """{position: [x, y, z], rotation: [x, y, z, w]} (each optional) -> (position, xyzw), checked."""
    pose = f.keys(("position", "rotation"))
    position = pose["position"].vec(3, "finite") if "position" in pose else (0.0, 0.0, 0.0)
    rotation = pose["rotation"].rotation() if "rotation" in pose else (0.0, 0.0, 0.0, 1.0)
    return position, rotation


def _quat_matrix(q) -> np.ndarray:
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


RATE_KEYS = {"physics_rate": "physics", "particle_rate": "particles"}


def rates_problem(physics_rate: float, publish_rate: float, particle_rate: float = 0.0) -> tuple[str, str] | None:
    """(the field to change, why) when the engine cannot run these rates, else None: it runs whole
    substeps of the bodies (physics_rate) and of the particles (particle_rate; 0: physics_rate)
    in every published tick, the particles no more often than the bodies."""
    for name, rate in (("physics_rate", physics_rate), ("particle_rate", particle_rate or physics_rate)):
        ratio = rate / publish_rate
        if abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1:
            return name, f"{rate:g} Hz is not an integer multiple of the publish rate {publish_rate:g} Hz"
    if particle_rate > physics_rate:
        return "particle_rate", (f"{particle_rate:g} Hz is above the physics rate {physics_rate:g} Hz (the particles "
                                 "substep at most as often as the bodies)")
    return None


__all__ = ["DEFAULT_SCENE", "DYNAMICS", "ROBOTS", "SENSORS", "Scene", "SceneError", "find_scene", "load_scene", "parse_scene"]
