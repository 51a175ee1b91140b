"""The twin's scene description (scenes/psm_twin.yaml): parsing with line-numbered errors. Below
the twin and the tasks, which both read it (a task runs in the twin's world: envs/tissue_retract.py).

The file is small YAML. We parse it with yaml.compose (not safe_load) so that every value
keeps its node and so its line: a bad field is reported as `psm_twin.yaml:12:3: arm.base.
position: expected 3 numbers, got 2`, which is what a user editing the file needs. Unknown
keys are errors too (a typo such as `num_env` would otherwise be silently ignored).
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

SCENE_DIR_ENV = "CRESSIM_SCENE_DIR"  # overrides where scenes/ is (an install outside the repo)
DEFAULT_SCENE = "psm_twin.yaml"
ROBOTS = ("psm_lnd", "psm_suction")
DYNAMICS = ("kinematic", "dynamic")  # arm.dynamics: the arm's links follow the twin, or are simulated
SENSORS = ("joints", "cartesian", "velocity", "wrench", "jacobian", "tf", "clock", "color", "depth", "segmentation", "ultrasound")


CART_ARMS = {"ECM": "ecm", "PSM1": "psm", "PSM2": "psm", "PSM3": "psm", "MTML": "mtm", "MTMR": "mtm"}
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


class SceneError(ValueError):
    """A bad scene file; the message starts with `file:line:column:`."""


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
    try:
        text = path.read_text()
    except OSError as exc:
        raise SceneError(f"{path}: {exc}") from None
    return parse_scene(text, str(path))


def parse_scene(text: str, path: str = "<string>") -> Scene:
    try:
        root = yaml.compose(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"{path}:{mark.line + 1}:{mark.column + 1}" if mark else path
        raise SceneError(f"{where}: not valid YAML: {getattr(exc, 'problem', exc)}") from None
    scene = Scene(path=path)
    if root is None:  # an empty file: all defaults
        return scene
    p = _Parser(path)
    top = p.mapping(root, "", {"arm", "num_envs", "rates", "camera", "sensors", "record", "world", "cart"})
    if "arm" in top:
        arm = p.mapping(top["arm"], "arm", {"name", "robot", "dynamics", "base", "initial_jp", "initial_jaw",
                                            "home_jp", "measured_lag", "trajectory", "stale_command_after",
                                            "grasp", "suction", "cautery", "needle"})
        if "name" in arm:
            scene.arm = p.name(arm["name"], "arm.name")
        if "robot" in arm:
            scene.robot = p.choice(arm["robot"], "arm.robot", ROBOTS)
        if "dynamics" in arm:
            scene.dynamics = p.choice(arm["dynamics"], "arm.dynamics", DYNAMICS)
        if "base" in arm:
            base = p.mapping(arm["base"], "arm.base", {"position", "rotation"})
            if "position" in base:
                scene.base_position = p.numbers(base["position"], "arm.base.position", 3)
            if "rotation" in base:
                q = p.numbers(base["rotation"], "arm.base.rotation", 4)
                norm = math.sqrt(sum(v * v for v in q))
                if abs(norm - 1.0) > 1e-3:
                    p.fail(base["rotation"], "arm.base.rotation", f"quaternion x, y, z, w of norm 1 expected, norm is {norm:.6g}")
                scene.base_rotation = tuple(v / norm for v in q)
        if "initial_jp" in arm:
            scene.initial_jp = p.numbers(arm["initial_jp"], "arm.initial_jp", 6)
        if "initial_jaw" in arm:
            scene.initial_jaw = p.number(arm["initial_jaw"], "arm.initial_jaw")
        if "home_jp" in arm:
            scene.home_jp = None if _is_null(arm["home_jp"]) else p.numbers(arm["home_jp"], "arm.home_jp", 6)
        if "measured_lag" in arm:
            scene.measured_lag = p.number(arm["measured_lag"], "arm.measured_lag", low=0.0, high=1.0)
        if "stale_command_after" in arm:
            scene.stale_command_after = p.number(arm["stale_command_after"], "arm.stale_command_after", low=0.0)
        if "grasp" in arm:
            grasp = p.mapping(arm["grasp"], "arm.grasp", {"reach", "closed_below"})
            if "reach" in grasp:
                scene.grasp_reach = p.number(grasp["reach"], "arm.grasp.reach", low=1e-4, high=0.05)
            if "closed_below" in grasp:
                scene.grasp_closed_below = p.number(grasp["closed_below"], "arm.grasp.closed_below", low=-0.7,
                                                    high=1.4)
        if "suction" in arm:
            suction = p.mapping(arm["suction"], "arm.suction", {"radius", "flow_rate", "reach"})
            if "radius" in suction:
                scene.suction_radius = p.number(suction["radius"], "arm.suction.radius", low=1e-4, high=0.05)
            if "flow_rate" in suction:
                scene.suction_flow_rate = p.number(suction["flow_rate"], "arm.suction.flow_rate", low=0.0, high=1e-3)
            if "reach" in suction:
                scene.suction_reach = p.number(suction["reach"], "arm.suction.reach", low=1e-4, high=0.2)
            if scene.suction_reach < scene.suction_radius:
                p.fail(suction.get("reach", arm["suction"]), "arm.suction.reach",
                       f"{scene.suction_reach:g} m is less than the radius {scene.suction_radius:g} m")
        if "cautery" in arm:
            cautery = p.mapping(arm["cautery"], "arm.cautery", {"radius", "power", "mode"})
            if "radius" in cautery:
                scene.cautery_radius = p.number(cautery["radius"], "arm.cautery.radius", low=1e-4, high=0.02)
            if "power" in cautery:
                scene.cautery_power = p.number(cautery["power"], "arm.cautery.power", low=0.0, high=300.0)
            if "mode" in cautery:
                scene.cautery_mode = p.choice(cautery["mode"], "arm.cautery.mode", ("coag", "cut"))
        if "needle" in arm:
            fields = {"arc_radius": (1e-3, 0.05, 0.008), "arc_angle": (0.5, 5.0, 3 * math.pi / 4),
                      "puncture_force": (1e-3, 100.0, 1.0), "puncture_depth": (1e-4, 0.02, 0.002),
                      "friction": (0.0, 2.0, 0.3), "squeeze": (0.0, 10.0, 0.0), "thread_length": (0.005, 0.5, 0.06)}
            needle = p.mapping(arm["needle"], "arm.needle", set(fields))
            scene.needle = {k: (p.number(needle[k], f"arm.needle.{k}", low=lo, high=hi) if k in needle else default)
                            for k, (lo, hi, default) in fields.items()}
        if "trajectory" in arm:
            traj = p.mapping(arm["trajectory"], "arm.trajectory", {"velocity_ratio", "acceleration_ratio"})
            if "velocity_ratio" in traj:
                scene.velocity_ratio = p.number(traj["velocity_ratio"], "arm.trajectory.velocity_ratio",
                                                low=1e-3, high=1.0)
            if "acceleration_ratio" in traj:
                scene.acceleration_ratio = p.number(traj["acceleration_ratio"], "arm.trajectory.acceleration_ratio",
                                                    low=1e-3, high=1e3)
    if "cart" in top:
        _parse_cart(p, top["cart"], scene)
    if "num_envs" in top:
        scene.num_envs = p.integer(top["num_envs"], "num_envs", low=1, high=4096)
    if "rates" in top:
        keys = ("physics", "particles", "publish", "tf", "camera", "ultrasound")
        rates = p.mapping(top["rates"], "rates", set(keys))
        for key in keys:
            if key in rates:
                name = "particle_rate" if key == "particles" else f"{key}_rate"
                low = 0.0 if key == "particles" else 0.1  # particles 0: as physics
                setattr(scene, name, p.number(rates[key], f"rates.{key}", low=low, high=10000.0))
                scene.lines[name] = p.where(rates[key])
    if "camera" in top:
        cam = p.mapping(top["camera"], "camera", {"width", "height", "fov_y", "position", "look_at"})
        if "width" in cam:
            scene.camera_width = p.integer(cam["width"], "camera.width", low=1, high=8192)
        if "height" in cam:
            scene.camera_height = p.integer(cam["height"], "camera.height", low=1, high=8192)
        if "fov_y" in cam:
            scene.camera_fov_y = p.number(cam["fov_y"], "camera.fov_y", low=1.0, high=170.0)
        if "position" in cam:
            scene.camera_position = p.numbers(cam["position"], "camera.position", 3)
        if "look_at" in cam:
            scene.camera_look_at = p.numbers(cam["look_at"], "camera.look_at", 3)
        gap = math.dist(scene.camera_position, scene.camera_look_at)
        if gap < 1e-6:
            p.fail(cam.get("look_at", cam.get("position", top["camera"])), "camera.look_at",
                   "the camera looks at its own position; give a point away from camera.position")
    if "sensors" in top:
        node = top["sensors"]
        if not isinstance(node, yaml.SequenceNode):
            p.fail(node, "sensors", f"a list of {', '.join(SENSORS)} expected")
        scene.sensors = tuple(p.choice(item, "sensors", SENSORS) for item in node.value)
    if "record" in top:
        scene.record = "" if _is_null(top["record"]) else p.string(top["record"], "record")
    if "world" in top and not _is_null(top["world"]):
        name = p.string(top["world"], "world")
        try:  # beside the twin's file, or by name in scenes/
            found = Path(path).parent / name if (Path(path).parent / name).is_file() else find_scene(name)
        except SceneError:
            p.fail(top["world"], "world", f"no scene file {name!r} (beside {path} or in scenes/)")
        scene.world = str(found)
    # a check across fields, reported at the line of the one to change
    problem = rates_problem(scene.physics_rate, scene.publish_rate, scene.particle_rate)
    if problem:
        name, why = problem
        raise SceneError(f"{scene.lines.get(name, path)}: rates.{RATE_KEYS[name]}: {why}")
    return scene


def _parse_cart(p, node, scene):
    """`cart:` {ECM: {...}, PSM1: {...}, ...}: the arms of a patient cart, each with its base."""
    from cressim.robots.kinematics import rotation_xyzw
    from cressim.robots.suj import suj_base

    cart = p.mapping(node, "cart", set(CART_ARMS) | {"operator", "origin"})
    origin = np.eye(4)  # the cart's frame (the setup joints' origin) in the world
    if "origin" in cart:
        position, rotation = _pose(p, cart["origin"], "cart.origin")
        origin[:3, :3], origin[:3, 3] = _quat_matrix(rotation), position
    arms = []
    for name, arm_node in cart.items():
        if name in ("operator", "origin"):
            continue
        kind = CART_ARMS[name]
        keys = ({"base", "setup_joints"} if kind != "mtm" else set()) \
            | ({"robot", "initial_jp", "home_jp"} if kind == "psm" else set()) \
            | ({"initial_jp", "home_jp", "endoscope"} if kind == "ecm" else set())
        fields = p.mapping(arm_node, f"cart.{name}", keys) if not _is_null(arm_node) else {}
        values = dict(name=name, kind=kind)
        if "base" in fields and "setup_joints" in fields:
            p.fail(fields["setup_joints"], f"cart.{name}.setup_joints", "give either base or setup_joints")
        if "setup_joints" in fields:  # the dVRK Classic SUJ puts the base there (cressim.robots.suj)
            base = origin @ suj_base(name, p.numbers(fields["setup_joints"], f"cart.{name}.setup_joints", 6))
            values["base_position"] = tuple(float(v) for v in base[:3, 3])
            values["base_rotation"] = rotation_xyzw(base[:3, :3])
        if "base" in fields:  # the base's pose in the world, as given
            values["base_position"], values["base_rotation"] = _pose(p, fields["base"], f"cart.{name}.base")
        if "robot" in fields:
            values["robot"] = p.choice(fields["robot"], f"cart.{name}.robot", ROBOTS)
        dof = 4 if kind == "ecm" else 6
        for key in ("initial_jp", "home_jp"):
            if key in fields:
                values[key] = p.numbers(fields[key], f"cart.{name}.{key}", dof)
        if "endoscope" in fields:
            scope = p.mapping(fields["endoscope"], f"cart.{name}.endoscope", {"baseline"})
            if "baseline" in scope:
                scene.endoscope_baseline = p.number(scope["baseline"], f"cart.{name}.endoscope.baseline",
                                                    low=1e-4, high=0.05)
        arms.append(CartArm(**values))
    if not any(a.kind == "ecm" for a in arms) or not any(a.kind == "psm" for a in arms):
        p.fail(node, "cart", "a cart needs the ECM and at least one PSM")
    scene.cart = tuple(arms)
    if "operator" in cart:
        scene.operator = _parse_operator(p, cart["operator"], [a.name for a in arms if a.kind == "mtm"])


def _parse_operator(p, node, mtms) -> tuple:
    """`cart.operator:` a list of keyframes {at: s, clutch/camera/present: bool, MTMx: {position:
    [x, y, z], gripper: rad}}, in time order."""
    if not isinstance(node, yaml.SequenceNode):
        p.fail(node, "cart.operator", "a list of keyframes {at, clutch, camera, present, MTML, MTMR} expected")
    frames, last = [], -math.inf
    for i, item in enumerate(node.value):
        key = f"cart.operator[{i}]"
        f = p.mapping(item, key, {"at", "clutch", "camera", "present", *mtms})
        if "at" not in f:
            p.fail(item, key, "every keyframe needs `at` (s)")
        at = p.number(f["at"], f"{key}.at", low=0.0, high=1e6)
        if at <= last:
            p.fail(f["at"], f"{key}.at", f"{at:g} s is not after the keyframe before ({last:g} s)")
        last = at
        pedals = {k: p.boolean(f[k], f"{key}.{k}") for k in ("clutch", "camera", "present") if k in f}
        hands, grips = {}, {}
        for name in mtms:
            if name in f:
                hand = p.mapping(f[name], f"{key}.{name}", {"position", "gripper"})
                if "position" in hand:
                    hands[name] = p.numbers(hand["position"], f"{key}.{name}.position", 3)
                if "gripper" in hand:
                    grips[name] = p.number(hand["gripper"], f"{key}.{name}.gripper", *GRIPPER_LIMITS)
        frames.append(Keyframe(at, hands, grips, pedals))
    return tuple(frames)


def _pose(p, node, key) -> tuple:
    """{position: [x, y, z], rotation: [x, y, z, w]} (each optional) -> (position, xyzw), checked."""
    pose = p.mapping(node, key, {"position", "rotation"})
    position = p.numbers(pose["position"], f"{key}.position", 3) if "position" in pose else (0.0, 0.0, 0.0)
    rotation = (0.0, 0.0, 0.0, 1.0)
    if "rotation" in pose:
        q = p.numbers(pose["rotation"], f"{key}.rotation", 4)
        norm = math.sqrt(sum(v * v for v in q))
        if abs(norm - 1.0) > 1e-3:
            p.fail(pose["rotation"], f"{key}.rotation", f"quaternion x, y, z, w of norm 1 expected, norm is {norm:.6g}")
        rotation = tuple(v / norm for v in q)
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


def _is_null(node) -> bool:
    return isinstance(node, yaml.ScalarNode) and node.tag == "tag:yaml.org,2002:null"


class _Parser:
    """Typed readers of YAML nodes; each failure names the field and its line."""

    def __init__(self, path):
        self.path = path

    def where(self, node) -> str:
        return f"{self.path}:{node.start_mark.line + 1}:{node.start_mark.column + 1}"

    def fail(self, node, key, problem):
        raise SceneError(f"{self.where(node)}: {key or 'top level'}: {problem}")

    def mapping(self, node, key, allowed) -> dict:
        if not isinstance(node, yaml.MappingNode):
            self.fail(node, key, f"a mapping with keys {', '.join(sorted(allowed))} expected")
        out = {}
        for k, v in node.value:
            name = k.value if isinstance(k, yaml.ScalarNode) else None
            full = f"{key}.{name}" if key else name
            if name not in allowed:
                self.fail(k, full, f"unknown field; expected one of {', '.join(sorted(allowed))}")
            if name in out:
                self.fail(k, full, "given twice")
            out[name] = v
        return out

    def scalar(self, node, key):
        if not isinstance(node, yaml.ScalarNode):
            self.fail(node, key, "a single value expected")
        return yaml.safe_load(yaml.serialize(node))  # the value with YAML's own typing

    def number(self, node, key, low=-math.inf, high=math.inf) -> float:
        value = self.scalar(node, key)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            self.fail(node, key, f"a finite number expected, got {node.value!r}")
        if not low <= value <= high:
            self.fail(node, key, f"{value:g} is outside [{low:g}, {high:g}]")
        return float(value)

    def boolean(self, node, key) -> bool:
        value = self.scalar(node, key)
        if not isinstance(value, bool):
            self.fail(node, key, f"true or false expected, got {node.value!r}")
        return value

    def integer(self, node, key, low, high) -> int:
        value = self.scalar(node, key)
        if isinstance(value, bool) or not isinstance(value, int):
            self.fail(node, key, f"an integer expected, got {node.value!r}")
        if not low <= value <= high:
            self.fail(node, key, f"{value} is outside [{low}, {high}]")
        return value

    def numbers(self, node, key, count) -> tuple:
        if not isinstance(node, yaml.SequenceNode):
            self.fail(node, key, f"a list of {count} numbers expected")
        if len(node.value) != count:
            self.fail(node, key, f"expected {count} numbers, got {len(node.value)}")
        return tuple(self.number(item, f"{key}[{i}]") for i, item in enumerate(node.value))

    def string(self, node, key) -> str:
        value = self.scalar(node, key)
        if not isinstance(value, str):
            self.fail(node, key, f"a string expected, got {node.value!r}")
        return value

    def name(self, node, key) -> str:
        value = self.string(node, key)
        if not value or not (value[0].isalpha() and all(c.isalnum() or c == "_" for c in value)):
            self.fail(node, key, f"{value!r} is not a valid ROS name (letters, digits, _; a letter first)")
        return value

    def choice(self, node, key, options) -> str:
        value = self.string(node, key)
        if value not in options:
            self.fail(node, key, f"{value!r} is not one of {', '.join(options)}")
        return value


__all__ = ["DEFAULT_SCENE", "DYNAMICS", "ROBOTS", "SENSORS", "Scene", "SceneError", "find_scene", "load_scene", "parse_scene"]
