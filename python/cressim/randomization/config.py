"""Domain randomization terms: what to randomize, how, and when, read and checked from a task's
config (Python dicts, errors named with their origin) or a scene file's `randomization:` section
(YAML, errors with file:line:column), both by cressim.config's field reader.

A term::

    - param: mass                 # one of PARAMS
      entity: cart                # entity name (fnmatch pattern) in every env
      distribution: uniform       # uniform (range), log_uniform (range, > 0), gaussian (mean, std, clip),
                                  # choice (choices: one of the listed values, each as likely)
      range: [0.5, 2.0]           # [low, high], one pair for every component or one pair per component
      operation: scale            # scale (x authored), add (+ authored) or abs (the value itself)
      when: reset                 # reset (each env's episode start) or interval (every `every` steps)
      name: cart_mass             # key of its sampled values (default "<param>/<entity>")
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from cressim.config import Field, FieldError, read_fields

INF = math.inf


@dataclass(frozen=True)
class Param:
    """A randomizable parameter: the buffers it writes (`kind`), its code in randomize.hlsl, the
    number of components, the operations that make sense and the values it may take."""

    kind: str  # bodies, colliders, joints, objects, tets, renderables, lights, transforms, probes, depth
    code: int
    size: int
    operations: tuple
    low: float  # allowed values [low, high], low excluded when `open_low`
    high: float
    open_low: bool
    unit: str
    doc: str


# the codes match the PARAM_* constants of randomize.hlsl
PARAMS = {
    "mass": Param("bodies", 1, 1, ("scale", "add", "abs"), 0, INF, True, "kg",
                  "a dynamic rigid body's mass, its inertia scaled with it (same shape); or a particle "
                  "object's (soft body, fluid, strand) total, every free particle's mass scaled alike"),
    "damping": Param("bodies", 2, 1, ("scale", "add", "abs"), 0, INF, False, "1/s",
                     "a rigid body's linear and angular damping, or a particle object's (soft body, fluid, strand)"),
    "friction": Param("colliders", 3, 1, ("scale", "add", "abs"), 0, INF, False, "",
                      "a collider's static and dynamic friction coefficients, or a particle object's friction"),
    "restitution": Param("colliders", 4, 1, ("scale", "add", "abs"), 0, 1, False, "", "a collider's restitution"),
    "joint_stiffness": Param("joints", 5, 1, ("scale", "add", "abs"), 0, INF, False, "N/m or N m/rad",
                             "a joint drive's stiffness"),
    "joint_damping": Param("joints", 6, 1, ("scale", "add", "abs"), 0, INF, False, "N s/m or N m s/rad",
                           "a joint drive's damping"),
    "youngs_modulus": Param("tets", 7, 1, ("scale", "add", "abs"), 0, INF, True, "Pa",
                            "an elastic soft body's Young's modulus (its Poisson ratio kept)"),
    "stiffness": Param("constraints", 16, 1, ("scale",), 0, INF, True, "",
                       "a soft body's or strand's XPBD constraints (distance, volume, bend, stretch, "
                       "bend and twist) made this many times stiffer: their compliances divided by it"),
    "color": Param("renderables", 8, 3, ("scale", "add", "abs"), 0, 1, False, "linear RGB",
                   "a renderable's base colour"),
    "light_intensity": Param("lights", 9, 1, ("scale", "add", "abs"), 0, INF, False, "",
                             "a light's intensity"),
    "light_color": Param("lights", 10, 3, ("scale", "add", "abs"), 0, 1, False, "linear RGB", "a light's colour"),
    "ambient": Param("environment", 17, 1, ("scale",), 0, INF, False, "",
                     "the ambient light of the env of a light or environment entity: its sky and ground "
                     "colours (and environment map) scaled by the draw"),
    "camera_position": Param("transforms", 11, 3, ("add", "abs"), -INF, INF, False, "m",
                             "a camera's position (its env frame)"),
    "camera_rotation": Param("transforms", 12, 3, ("add",), -INF, INF, False, "rad",
                             "a camera's orientation turned by a rotation vector in the camera's own frame"),
    "depth_noise": Param("depth", 13, 1, ("add", "abs"), 0, INF, False, "m",
                         "standard deviation of zero-mean gaussian noise added to a camera's depth image, "
                         "drawn anew for every pixel and frame"),
    "texture": Param("renderables", 15, 1, ("abs",), -1, INF, False, "texture index",
                     "a renderable's colour texture: an index of World.add_texture (in a scene file also a name "
                     "of its textures), -1 none; drawn by distribution choice"),
    "ultrasound_gain": Param("probes", 14, 1, ("add", "abs", "scale"), -INF, INF, False, "dB",
                             "an ultrasound probe's gain (the image's envelope scales by 10^(dB/20))"),
}
DISTRIBUTIONS = ("uniform", "log_uniform", "gaussian", "choice")
OPERATIONS = ("scale", "add", "abs")
WHEN = ("reset", "interval")
TERM_KEYS = ("param", "entity", "distribution", "range", "mean", "std", "clip", "choices", "operation", "when", "every",
             "name")


# a randomization config that cannot be used: the one error of configuration (file:line:column,
# or the origin of a Python config, then the field), also for a term that does not fit a world
RandomizationError = FieldError


@dataclass(frozen=True)
class Term:
    """One checked term. Per component: `low`, `high` the range (uniform, log_uniform), mean and
    standard deviation (gaussian) or least and greatest choice; `clip` bounds a gaussian's draws
    (None: unbounded); `choices` the values of a choice (one component)."""

    name: str
    param: str
    entity: str
    distribution: str
    low: tuple
    high: tuple
    clip: tuple | None
    operation: str
    when: str
    every: int
    where: str  # file:line:column (or the origin) and field path, for later errors
    choices: tuple | None = None

    @property
    def spec(self) -> Param:
        return PARAMS[self.param]

    def bounds(self) -> tuple[tuple, tuple]:
        """The least and greatest value each component can draw (+-inf: unbounded)."""
        if self.distribution != "gaussian":
            return self.low, self.high
        if self.clip is None:
            return tuple(m if s == 0 else -INF for m, s in zip(self.low, self.high)), \
                tuple(m if s == 0 else INF for m, s in zip(self.low, self.high))
        return self.clip


def _pairs(f, size: int, what: str) -> tuple[tuple, tuple]:
    """[a, b] for every component, or one [a, b] per component: ((a...), (b...))."""
    items = f.list()
    if items and all(i.is_list() for i in items):
        if len(items) != size:
            raise f.fail(f"expected one [{what}] pair per component ({size}), got {len(items)}")
        pairs = [(i, i.list()) for i in items]
    else:
        pairs = [(f, items)] * size
    for field, p in pairs:
        if len(p) != 2:
            raise field.fail(f"expected [{what}], two numbers, got {len(p)}")
    return tuple(p[0].finite() for _, p in pairs), tuple(p[1].finite() for _, p in pairs)


def _numbers(f, size: int) -> tuple:
    """A number for every component, or a list of one per component."""
    if f.is_list():
        items = f.list()
        if len(items) != size:
            raise f.fail(f"expected {size} numbers (one per component), got {len(items)}")
        return tuple(i.finite() for i in items)
    return (f.finite(),) * size


def _choice(f, textures: dict | None) -> float:
    """A choice: a number, or (a texture) a scene file's texture name."""
    if textures is not None and not f.is_list() and not f.is_map():
        try:
            return f.finite()
        except ValueError:
            name = f.str()
            if name not in textures:
                raise f.fail(f"no texture named '{name}'; the textures are: {', '.join(textures) or '(none)'}") from None
            return float(textures[name])
    return f.finite()


def parse_term(f, index: int, textures: dict | None = None) -> Term:
    """One term from a mapping field (a cressim.config.Field of YAML or of Python values); raises naming the field.
    `textures`: a scene file's texture names and indices, which texture choices may name."""
    c = f.keys(TERM_KEYS)
    for key in ("param", "entity"):
        if key not in c:
            raise f.fail(f"a randomization term needs '{key}'")
    param = c["param"].str()
    if param not in PARAMS:
        raise c["param"].fail(f"unknown parameter '{param}'; expected one of: {', '.join(PARAMS)}")
    spec = PARAMS[param]
    entity = c["entity"].str()
    if not entity:
        raise c["entity"].fail("the entity name is empty")
    dist = c["distribution"].str() if "distribution" in c else "uniform"
    if dist not in DISTRIBUTIONS:
        raise c["distribution"].fail(f"unknown distribution '{dist}'; expected one of: {', '.join(DISTRIBUTIONS)}")
    clip = choices = None
    if dist != "choice" and "choices" in c:
        raise c["choices"].fail(f"'choices' is for distribution: choice, not {dist}")
    if param == "texture" and dist != "choice":
        raise f.fail("texture takes distribution: choice with choices: [texture indices]")
    if dist == "choice":
        for key in ("range", "mean", "std", "clip"):
            if key in c:
                raise c[key].fail(f"'{key}' is not for a choice; it takes choices: [values]")
        if "choices" not in c:
            raise f.fail("a choice needs choices: [values]")
        if spec.size != 1:
            raise c["choices"].fail(f"{param} has {spec.size} components; a choice draws one number")
        items = c["choices"].list()
        if not items:
            raise c["choices"].fail("give at least one value")
        choices = tuple(_choice(i, textures if param == "texture" else None) for i in items)
        if param == "texture" and any(v != int(v) or v < -1 for v in choices):
            raise c["choices"].fail(f"texture indices are integers >= -1 (-1: none), got {list(choices)}")
        low, high = (min(choices),), (max(choices),)
    elif dist == "gaussian":
        for key in ("mean", "std"):
            if key not in c:
                raise f.fail(f"a gaussian needs '{key}' (and optionally clip: [low, high])")
        if "range" in c:
            raise c["range"].fail("a gaussian takes mean, std and clip, not range")
        low, high = _numbers(c["mean"], spec.size), _numbers(c["std"], spec.size)
        if any(s < 0 for s in high):
            raise c["std"].fail(f"std must be >= 0, got {list(high)}")
        if "clip" in c:
            clip = _pairs(c["clip"], spec.size, "low, high")
            if any(a > b for a, b in zip(*clip)):
                raise c["clip"].fail(f"clip low must be <= high, got {[list(x) for x in clip]}")
    else:
        for key in ("mean", "std", "clip"):
            if key in c:
                raise c[key].fail(f"'{key}' is for a gaussian; {dist} takes range: [low, high]")
        if "range" not in c:
            raise f.fail(f"a {dist} distribution needs range: [low, high]")
        low, high = _pairs(c["range"], spec.size, "low, high")
        if any(a > b for a, b in zip(low, high)):
            raise c["range"].fail(f"low must be <= high, got low {list(low)}, high {list(high)}")
        if dist == "log_uniform" and any(a <= 0 for a in low):
            raise c["range"].fail(f"a log_uniform range must be positive, got low {list(low)}")
    op = c["operation"].str() if "operation" in c else spec.operations[0]
    if op not in OPERATIONS:
        raise c["operation"].fail(f"unknown operation '{op}'; expected one of: {', '.join(OPERATIONS)}")
    if op not in spec.operations:
        raise c["operation"].fail(f"{param} takes the operations {', '.join(spec.operations)}, not {op}")
    when = c["when"].str() if "when" in c else "reset"
    if when not in WHEN:
        raise c["when"].fail(f"unknown 'when' {when!r}; expected reset or interval")
    every = 0
    if when == "interval":
        if "every" not in c:
            raise f.fail("when: interval needs every: <steps> (an integer >= 1)")
        every = c["every"].int(1)
        if every >= 2 ** 31:
            raise c["every"].fail(f"must be < 2**31 steps, got {every}")
    elif "every" in c:
        raise c["every"].fail("'every' is for when: interval")
    name = c["name"].str() if "name" in c else f"{param}/{entity}"
    return Term(name, param, entity, dist, low, high, clip, op, when, every, f"{f.where}: {f.path}", choices)


def parse_terms(f, textures: dict | None = None) -> list[Term]:
    """The terms of a list field; term names must be distinct."""
    terms = [parse_term(item, i, textures) for i, item in enumerate(f.list())]
    seen = {}
    for t, item in zip(terms, f.list()):
        if t.name in seen:
            raise item.fail(f"term name '{t.name}' is used twice (also {seen[t.name]}); give each a distinct name:")
        seen[t.name] = t.where
    return terms


def load_terms(config, origin: str = "Randomizer(terms=...)") -> list[Term]:
    """Terms from `config`: a list of term dicts, a path to a YAML file (a scene file's
    `randomization:` section, or a file holding the list), or already parsed Terms."""
    if config is None:
        return []
    if isinstance(config, (str, Path)):
        return file_randomization(Path(config))
    if isinstance(config, (list, tuple)) and all(isinstance(t, Term) for t in config):
        return list(config)
    return parse_terms(Field.of(config, origin, "randomization"))


def file_randomization(path) -> list[Term]:
    """The terms of a scene file's `randomization:` section, or of a YAML file that is the list
    of terms itself; errors name file:line and the field."""
    root = read_fields(Path(path))
    if not root.is_map():
        return parse_terms(root)
    top = root.items()
    # texture choices may name the file's textures: their indices in a world of its own
    names = top["textures"].items() if "textures" in top else {}
    return parse_terms(top["randomization"], {n: i for i, n in enumerate(names)}) if "randomization" in top else []
