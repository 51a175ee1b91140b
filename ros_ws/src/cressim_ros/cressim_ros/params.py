"""The node's parameters: names, meaning, defaults (from the scene file) and validation.

`check` is the one validator: it runs on the start-up values (a bad value stops the node with
the reason before anything is built) and in the set-parameters callback (a bad change is
refused with the reason, returned in SetParametersResult.reason, and the node keeps running
with its old values). `check_params_files` reads the values of `--params-file` files before
the node starts, so a bad one is named with its file:line:column. Each value is read by
cressim.config's field reader (`read`); what stays here is what only ROS has: the parameters'
names, meaning and whether they change at run time, and the parameters file's layout. Structural parameters (scene, robot, dynamics, arm, num_envs,
physics_rate, particle_rate) size or build the engine and the topic graph, so they cannot change while the
node runs.
"""
from __future__ import annotations

import os
import re
import sys
from dataclasses import dataclass

from cressim.config import Field, FieldError, read_file
from cressim.twin.messages import ConfigError
from cressim.twin_scene_file import DYNAMICS, ROBOTS, SENSORS, Scene, rates_problem, ros_name

NODE = "cressim_twin"


@dataclass(frozen=True)
class Spec:
    name: str
    kind: type  # bool, int, float, str, list (of str)
    description: str
    runtime: bool  # may change while the node runs
    high: float = 0.0  # numbers: the largest value (0: MAX_RATE for rates, 8192 for integers)
    zero: bool = False  # 0 is a value too (particle_rate 0: the physics rate; live_view 0: off)


MAX_RATE = 2000.0
SPECS = (
    Spec("scene", str, "scene file (path, or a name in scenes/): arm variant, base pose, rates, ...", False),
    Spec("robot", str, f"instrument/arm variant: {', '.join(ROBOTS)} (robots/dvrk_psm/<robot>.urdf)", False),
    Spec("dynamics", str, f"arm simulation: {', '.join(DYNAMICS)} (links follow the twin's joints, or "
                          "jointed dynamic bodies driven to the setpoint)", False),
    Spec("arm", str, "arm name: ROS namespace (/PSM1) and frame prefix (PSM1_base)", False),
    Spec("num_envs", int, "number of twins in one engine; >1 puts env i under /env{i}/ARM", False, high=4096),
    Spec("physics_rate", float, "engine rate in Hz; an integer multiple of publish_rate", False, high=10 * MAX_RATE),
    Spec("particle_rate", float, "rate of the world's particles (tissue, blood, thread) in Hz; 0: physics_rate; "
                                 "an integer multiple of publish_rate, at most physics_rate", False,
         high=10 * MAX_RATE, zero=True),
    Spec("publish_rate", float, "rate of the periodic topics and of /clock, Hz (the dVRK's is 100)", True),
    Spec("tf_rate", float, "rate of the base -> tip transforms on /tf, Hz", True),
    Spec("camera_rate", float, "rate of the camera topics (color, depth, segmentation), Hz", True),
    Spec("ultrasound_rate", float, "rate of /ultrasound/image_raw, Hz (with the ultrasound sensor group)", True),
    Spec("camera_width", int, "camera image width, pixels (sizes the engine's render targets)", False),
    Spec("camera_height", int, "camera image height, pixels (sizes the engine's render targets)", False),
    Spec("sensors", list, f"sensor groups to publish: {', '.join(SENSORS)}", True),
    Spec("record", str, "MCAP recording (rosbag2 folder) path; empty: not recording", True),
    Spec("live_view", int, "port of the Foxglove WebSocket live view on this host (docs/twin.md); 0: off", False,
         high=65535, zero=True),
)
BY_NAME = {s.name: s for s in SPECS}


def defaults(scene: Scene) -> dict:
    return {"scene": scene.path, "robot": scene.robot, "dynamics": scene.dynamics, "arm": scene.arm, "num_envs": scene.num_envs,
            "physics_rate": scene.physics_rate, "particle_rate": scene.particle_rate,
            "publish_rate": scene.publish_rate, "tf_rate": scene.tf_rate,
            "camera_rate": scene.camera_rate, "ultrasound_rate": scene.ultrasound_rate, "camera_width": scene.camera_width,
            "camera_height": scene.camera_height, "sensors": list(scene.sensors), "record": scene.record,
            "live_view": 0}


def check(changes: dict, current: dict, *, running: bool) -> str | None:
    """None when `changes` (name -> value) may be applied on top of `current`, else why not."""
    merged = {**current, **changes}
    for name, value in changes.items():
        if name == "use_sim_time":
            if not isinstance(value, bool):
                return f"use_sim_time must be a bool, got {value!r}"
            continue
        spec = BY_NAME.get(name)
        if spec is None:
            return f"unknown parameter {name!r}; the twin has {', '.join(sorted(BY_NAME))}, use_sim_time"
        if running and not spec.runtime and value != current.get(name):
            return f"{name} cannot change while the node runs (it sizes the engine and topics): restart the node"
        try:
            read(spec, Field.of(value, "parameter", name))
        except FieldError as exc:
            return f"{exc.field}: {exc.reason}"
    problem = rates_problem(merged["physics_rate"], merged["publish_rate"], merged["particle_rate"])
    return f"{problem[0]}: {problem[1]} (the engine runs whole substeps per published tick)" if problem else None


def read(spec: Spec, f: Field):
    """The value of parameter `spec` in field `f` (of a parameters file, or a value ROS gives),
    checked by the one field reader; raises FieldError naming where and why."""
    if spec.kind is float:
        v = f.finite()
        return v if spec.zero and v == 0 else f.number(0.0, spec.high or MAX_RATE, "Hz", open_low=True)
    if spec.kind is int:
        v = f.int()
        return v if spec.zero and v == 0 else f.int(1, int(spec.high) or 8192)
    if spec.kind is list:
        return [g.choice(SENSORS) for g in f.list()]
    if spec.name == "robot":
        return f.choice(ROBOTS)
    if spec.name == "dynamics":
        return f.choice(DYNAMICS)
    if spec.name == "arm":
        return ros_name(f)
    value = f.str()
    if spec.name == "record" and value:
        parent = os.path.dirname(os.path.abspath(value))
        if not os.path.isdir(parent):
            raise f.fail(f"folder {parent} does not exist")
        if os.path.exists(value):
            raise f.fail(f"{value} exists already (a recording is never overwritten)")
    return value


def check_params_files(args=None, node: str = NODE) -> None:
    """Checks the node's values in every `--params-file` of the ROS arguments (`args`, else
    sys.argv) with file:line:column, before rclpy would take a bad one (a string for num_envs
    stops the node with a traceback there) or ignore a misspelt one; raises ConfigError."""
    argv = sys.argv if args is None else args
    files = [argv[i + 1] for i, a in enumerate(argv[:-1]) if a == "--params-file"]
    try:
        for path in files:
            root = read_file(path)
            if root is not None:
                _check_sections(root, "", node)
    except FieldError as exc:
        raise ConfigError(str(exc)) from None


def _check_sections(f: Field, prefix: str, node: str) -> None:
    """A parameters file's mapping: node names (namespaced, nested or with wildcards) down to
    `ros__parameters`. Sections for other nodes are not this node's to check."""
    for key, g in f.items().items():
        if key != "ros__parameters":
            if g.is_map():
                _check_sections(g, f"{prefix}/{key.strip('/')}", node)
            continue
        if not _matches(prefix, node):
            continue
        explicit = "*" not in prefix  # a wildcard section holds other nodes' parameters too
        params = g.keys(tuple(BY_NAME) + ("use_sim_time",)) if explicit else g.items()
        for name, value in params.items():
            if name == "use_sim_time":
                value.bool()
            elif name in BY_NAME:
                read(BY_NAME[name], value)


def _matches(pattern: str, node: str) -> bool:
    """rcl's node-name matching: `*` one name, `/**` any namespaces."""
    rule = re.escape(pattern).replace(r"/\*\*", "(/[^/]+)*").replace(r"\*", "[^/]*")
    return re.fullmatch(rule, "/" + node.strip("/")) is not None


def markdown(scene: Scene) -> str:
    """The parameter table of docs/twin.md (a test keeps the two equal)."""
    values = defaults(scene)
    rows = ["| parameter | meaning | default (scene file) | at run time |", "|---|---|---|---|"]
    for spec in SPECS:
        value = values[spec.name]
        shown = ", ".join(value) if isinstance(value, list) else (f"{value:g}" if isinstance(value, float) else value)
        if spec.name == "scene":
            shown = "psm_twin.yaml"
        shown = f"`{shown}`" if shown != "" else "(off)"
        rows.append(f"| `{spec.name}` | {spec.description} | {shown} | {'yes' if spec.runtime else 'no'} |")
    return "\n".join(rows) + "\n"


__all__ = ["BY_NAME", "NODE", "SPECS", "Spec", "check", "check_params_files", "defaults", "markdown", "read"]
