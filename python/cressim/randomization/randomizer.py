"""The Randomizer: a config's terms resolved to rows of the engine's buffers once, then recorded
as compute passes into each frame (randomize.hlsl): host work per step is O(1) in envs.

A frame with randomization (VectorEnv does this)::

    r.sample(reset_all)      # before reset_flagged_envs: sees env.reset_mask; draws
    engine.reset_flagged_envs()
    r.apply()                # writes the draws into bodies, colliders, ... (after the reset,
                             # which puts camera transforms back)
    ... sensors ...
    r.after_sensors()        # depth noise, before anything reads the images
"""
from __future__ import annotations

import fnmatch
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import cressim

from .config import INF, RandomizationError, Term, load_terms

HLSL = Path(__file__).with_name("randomize.hlsl")
DISTRIBUTION_CODES = {"uniform": 0, "log_uniform": 1, "gaussian": 2, "choice": 3}
OPERATION_CODES = {"scale": 0, "add": 1, "abs": 2}
WHEN_CODES = {"reset": 0, "interval": 1}
NONE = 0xFFFFFFFF
# XPBD constraint families and which of params.x, params.y hold compliances (stretch_shear has none)
COMPLIANCES = {"distance": (0, 1), "volume": (0, 1), "bend": (0, 1), "stretch": (0, 1), "bend_twist": (1, 1)}

# words of the model structs (shaders/common/*.h) that hold the randomized fields
BODY_WORDS, COLLIDER_WORDS, JOINT_WORDS, OBJECT_WORDS = 12, 20, 28, 36
RENDERABLE_WORDS, LIGHT_WORDS, CONSTRAINT_WORDS = 16, 16, 8


@dataclass
class Target:
    """One row a term writes: its env, the row, the authored values (4 floats), and the scalar
    authored values the drawn operation acts on (for the range check)."""

    term: int
    env: int
    row: int
    nominal: tuple
    acted_on: tuple
    entity: int
    group: int = 0  # probes: the ultrasound group whose buffer holds the row


class Randomizer:
    """Domain randomization of `engine` (uploaded) by `terms` (see config.py; dicts, a YAML path
    or Terms). Values per env are in the shared buffer `randomization_values` (envs, columns);
    `columns(name)` is a term's slice of them, `read(name)` a host copy."""

    def __init__(self, engine: cressim.Engine, terms, *, seed: int = 0, env_offset: int = 0,
                 episode_flags: tuple = ()):
        """`episode_flags`: up to two per-env int32 buffers (or keys), nonzero where an episode
        ended this step, for a task that starts episodes without the engine's reset."""
        self.engine = engine
        if len(episode_flags) > 2:
            raise ValueError("Randomizer: give at most two episode_flags buffers")
        self._episode_flags = list(episode_flags) + ["env.reset_mask"] * (2 - len(episode_flags))
        self.terms: list[Term] = load_terms(terms)
        if not self.terms:
            raise RandomizationError("randomization: no terms given")
        where = {}
        for t in self.terms:  # a scene file's terms and a task's side by side
            if t.name in where:
                raise RandomizationError(f"{t.where}: term name '{t.name}' is also used at {where[t.name]}; "
                                         "give each term a distinct name")
            where[t.name] = t.where
        self.num_envs = int(engine.world.layout.num_envs)
        self.env_offset, self.seed = int(env_offset), int(seed)
        self._world = engine.world
        m = engine.mapping
        self._row_entity = np.asarray(m["entity_id"])
        self._row_env = np.asarray(m["env_index"])
        self._entity_row = np.asarray(m["entity_row"])
        self._names = [self._world.entity(int(e)).name for e in self._row_entity]  # per row
        self._keys = set(engine.internal_keys)
        # value columns: each term's components side by side
        self._columns, first = {}, 0
        for t in self.terms:
            self._columns[t.name] = slice(first, first + t.spec.size)
            first += t.spec.size
        self.column_count = first
        self._targets = self._resolve()
        self._create_buffers()
        self._create_passes()

    # --- the frame ---------------------------------------------------------------------------
    def sample(self, reset_all: bool = False) -> None:
        """Records the draws: every term in every env (`reset_all`), else reset terms in envs
        flagged in env.reset_mask and interval terms that are due."""
        self.engine.execute_compute_pass(self._sample[bool(reset_all)])

    def apply(self) -> None:
        """Records the writes of this frame's draws (and of every term of an env that reset)."""
        for p in self._apply:
            self.engine.execute_compute_pass(p)

    def after_sensors(self) -> None:
        """Records the depth noise on the cameras' depth images (after they rendered)."""
        for p in self._noise:
            self.engine.execute_compute_pass(p)

    def set_seed(self, seed: int) -> None:
        self.seed = int(seed)
        for p in self._all_passes():
            p.set_constant("seed", self.seed)

    # --- inspection --------------------------------------------------------------------------
    @property
    def names(self) -> list[str]:
        return [t.name for t in self.terms]

    def columns(self, name: str) -> slice:
        """The columns of `randomization_values` that term `name` fills."""
        if name not in self._columns:
            raise KeyError(f"randomization: no term named {name!r}; the terms are: {', '.join(self._columns)}")
        return self._columns[name]

    def read(self, name: str | None = None) -> np.ndarray:
        """A host copy of the drawn values: (envs, components) of term `name`, or every column."""
        v = self.values.read().reshape(self.num_envs, self.column_count)
        return v if name is None else v[:, self.columns(name)].copy()

    def targets(self, name: str) -> list[tuple[int, int]]:
        """(env, entity id) of every row term `name` writes."""
        self.columns(name)  # raises for an unknown name
        k = self.names.index(name)
        return [(t.env, t.entity) for rows in self._targets.values() for t in rows if t.term == k]

    # --- set-up ------------------------------------------------------------------------------
    def _read(self, key: str, words: int, dtype=np.float32) -> np.ndarray:
        return np.ascontiguousarray(self.engine.buffer(key).read()).view(dtype).reshape(-1, words)

    def _matching(self, term: Term, rows) -> list[int]:
        return [r for r in rows if fnmatch.fnmatchcase(self._names[r], term.entity)]

    def _fail_none(self, term: Term, what: str, rows) -> RandomizationError:
        names = sorted({self._names[r] for r in rows if self._names[r]})
        return RandomizationError(f"{term.where}: {term.param}: no {what} named '{term.entity}' "
                                  f"(entities with one: {', '.join(names) or 'none'})")

    def _resolve(self) -> dict:
        """Every term's target rows by kind, checked: one writer per field, values in range."""
        targets: dict[str, list[Target]] = {}
        written: dict[tuple, str] = {}
        for k, term in enumerate(self.terms):
            kind, rows = getattr(self, "_rows_" + term.spec.kind)(k, term)
            for t in rows:
                field = (kind, t.group, t.row, "light" if term.param.startswith("light_") else term.param)
                if field in written:
                    raise RandomizationError(f"{term.where}: {term.param} of '{self._world.entity(t.entity).name}' "
                                             f"in env {t.env} is already randomized by {written[field]}")
                written[field] = term.where
                self._check_range(term, t)
            targets.setdefault(kind, []).extend(rows)
        return targets

    def _check_range(self, term: Term, t: Target) -> None:
        spec = term.spec
        if spec.low == -INF and spec.high == INF:
            return
        lows, highs = term.bounds()
        for n in t.acted_on:
            for lo, hi in zip(lows, highs):
                if term.operation == "scale":  # (an authored 0 stays 0 whatever the draw)
                    ends = (n * lo if n else 0.0, n * hi if n else 0.0)
                elif term.operation == "add":
                    ends = (n + lo, n + hi)
                else:
                    ends = (lo, hi)
                a, b = min(ends), max(ends)
                bad_low = a <= spec.low if spec.open_low else a < spec.low
                if bad_low or b > spec.high or math.isnan(a) or math.isnan(b):
                    entity = self._world.entity(t.entity).name
                    domain = f"{'(' if spec.open_low else '['}{spec.low:g}, {spec.high:g}]"
                    hint = " (a gaussian needs clip: [low, high] here)" if term.distribution == "gaussian" and \
                        term.clip is None else ""
                    raise RandomizationError(
                        f"{term.where}: {term.param} of '{entity}' (env {t.env}, authored {n:g}"
                        f"{' ' + spec.unit if spec.unit else ''}) would reach [{a:g}, {b:g}] with operation "
                        f"{term.operation}; it must stay in {domain}{hint}")

    def _rigid_rows(self):
        if "rigid.bodies" not in self._keys:
            return np.zeros(0, np.uint32), np.zeros((0, BODY_WORDS), np.float32)
        return (np.asarray(self.engine.buffer("rigid.body_entity").read()).ravel(),
                self._read("rigid.bodies", BODY_WORDS))

    def _particle_objects(self):
        if "particles.objects" not in self._keys:
            return np.zeros((0, OBJECT_WORDS), np.uint32)
        return self._read("particles.objects", OBJECT_WORDS, np.uint32)

    def _rows_bodies(self, k: int, term: Term):
        body_entity, bodies = self._rigid_rows()
        body_rows = [int(self._entity_row[e]) for e in body_entity]
        rows = self._matching(term, body_rows)
        objects = [int(o[4]) for o in self._particle_objects()]
        if not rows and self._matching(term, objects):  # a particle object's
            return self._rows_particles(k, term) if term.param == "mass" else self._rows_objects(k, term)
        if not rows:
            raise self._fail_none(term, "rigid body or particle object", body_rows + objects)
        row_body = {int(self._entity_row[e]): b for b, e in enumerate(body_entity)}
        out = []
        for r in rows:
            b = row_body[r]
            inv = bodies[b, 0:4]
            if term.param == "mass":
                if not inv[3] > 0:
                    raise RandomizationError(f"{term.where}: mass: '{self._names[r]}' (env {self._row_env[r]}) is "
                                             "kinematic; only dynamic bodies have a mass to randomize")
                out.append(Target(k, int(self._row_env[r]), b, tuple(inv), (1.0 / float(inv[3]),),
                                  int(self._row_entity[r])))
            else:
                d = bodies[b, 4:8]
                out.append(Target(k, int(self._row_env[r]), b, tuple(d), (float(d[0]), float(d[1])),
                                  int(self._row_entity[r])))
        return "bodies", out

    def _rows_colliders(self, k: int, term: Term):
        # colliders are stored env by env, row by row, a record per shape (rigid_model.cpp)
        owners = []
        if "rigid.colliders" in self._keys:
            for r, e in enumerate(self._row_entity):
                ent = self._world.entity(int(e))
                if ent.has(cressim.Collider):
                    owners += [r] * len(ent.collider.shapes)
            colliders = self._read("rigid.colliders", COLLIDER_WORDS)
            if len(owners) != len(colliders):
                raise RuntimeError(f"randomization: {len(owners)} collider shapes in the world, "
                                   f"{len(colliders)} in rigid.colliders")
        rows = self._matching(term, sorted(set(owners)))
        objects = [int(o[4]) for o in self._particle_objects()]
        if not rows and term.param == "friction" and self._matching(term, objects):
            return self._rows_objects(k, term)
        if not rows:
            raise self._fail_none(term, "collider" + (" or particle object" if term.param == "friction" else ""),
                                  owners + (objects if term.param == "friction" else []))
        out = []
        for c, r in enumerate(owners):
            if r in rows:
                mat = colliders[c, 12:16]
                acted = (float(mat[0]), float(mat[1])) if term.param == "friction" else (float(mat[2]),)
                out.append(Target(k, int(self._row_env[r]), c, tuple(mat), acted, int(self._row_entity[r])))
        return "colliders", out

    def _rows_joints(self, k: int, term: Term):
        entity = np.asarray(self.engine.buffer("joint.entity").read()).ravel() if "joint.model" in self._keys else []
        rows = [int(self._entity_row[e]) for e in entity]
        match = set(self._matching(term, rows))
        if not match:
            raise self._fail_none(term, "joint", rows)
        joints = self._read("joint.model", JOINT_WORDS)
        i = 0 if term.param == "joint_stiffness" else 1
        return "joints", [Target(k, int(self._row_env[r]), j, tuple(joints[j, 20:24]), (float(joints[j, 20 + i]),),
                                 int(self._row_entity[r])) for j, r in enumerate(rows) if r in match]

    def _rows_objects(self, k: int, term: Term):
        objects = self._particle_objects()
        rows = [int(o[4]) for o in objects]
        match = set(self._matching(term, rows))
        mat = objects[:, 8:12].view(np.float32)
        i = 1 if term.param == "friction" else 2
        return "objects", [Target(k, int(self._row_env[r]), o, tuple(mat[o]), (float(mat[o, i]),),
                                  int(self._row_entity[r])) for o, r in enumerate(rows) if r in match]

    def _rows_particles(self, k: int, term: Term):
        """A particle object's mass: every free particle's (inverse mass w > 0) scaled alike."""
        objects = self._particle_objects()
        rows = [int(o[4]) for o in objects]
        match = {o for o, r in enumerate(rows) if fnmatch.fnmatchcase(self._names[r], term.entity)}
        phases = self._read("particles.phases", 4, np.uint32)
        w = self._read("particles.initial_positions", 4)[:, 3]
        owner = phases[:, 1].astype(np.int64)
        free = (w > 0) & np.isin(owner, list(match))
        total = {o: float((1.0 / w[free & (owner == o)]).sum()) for o in match}
        out = []
        for i in np.flatnonzero(free):
            r = rows[owner[i]]
            out.append(Target(k, int(self._row_env[r]), int(i), (float(w[i]), total[owner[i]], 0.0, 0.0),
                              (total[owner[i]],), int(self._row_entity[r])))
        if not out:
            raise RandomizationError(f"{term.where}: mass: '{term.entity}' has no free particles (all fixed)")
        return "particles", out

    def _rows_constraints(self, k: int, term: Term):
        """The object's records of every XPBD family (one pass a family: group = its index)."""
        objects = self._particle_objects()
        rows = [int(o[4]) for o in objects]
        match = {o for o, r in enumerate(rows) if fnmatch.fnmatchcase(self._names[r], term.entity)}
        if not match:
            raise self._fail_none(term, "particle object", rows)
        phases = self._read("particles.phases", 4, np.uint32)
        n = len(phases)
        edges = (np.asarray(self.engine.buffer("particles.edge_particles").read()).ravel()
                 if "particles.edge_particles" in self._keys else np.zeros(0, np.uint32))
        out = []
        for g, (family, fields) in enumerate(COMPLIANCES.items()):
            key = f"particles.{family}_constraints"
            if key not in self._keys:
                continue
            records = self._read(key, CONSTRAINT_WORDS, np.uint32)
            params = records[:, 4:8].view(np.float32)
            for c, rec in enumerate(records):
                # its first particle (frame ids, >= n, stand for their segment's first particle)
                first = next((int(q) for q in rec[:4] if q != NONE), None)
                if first is None:
                    continue
                p = first if first < n else int(edges[first - n])
                obj = int(phases[p, 1])
                if obj in match:
                    r = rows[obj]
                    out.append(Target(k, int(self._row_env[r]), c, (float(params[c, 0]), float(params[c, 1]),
                                                                    *map(float, fields)),
                                      (1.0,), int(self._row_entity[r]), g))
        if not out:
            raise RandomizationError(f"{term.where}: stiffness: '{term.entity}' has no XPBD constraints (an elastic "
                                     "tet body's stiffness is its youngs_modulus)")
        return "constraints", out

    def _rows_tets(self, k: int, term: Term):
        objects = self._particle_objects()
        rows = [int(o[4]) for o in objects]
        match = {o for o, r in enumerate(rows) if fnmatch.fnmatchcase(self._names[r], term.entity)}
        if not match or "particles.tet_constraints" not in self._keys:
            raise self._fail_none(term, "soft body (particle object)", rows)
        records = self._read("particles.tet_constraints", CONSTRAINT_WORDS, np.uint32)
        phases = self._read("particles.phases", 4, np.uint32)
        params = records[:, 4:8].view(np.float32)
        out = []
        for c, rec in enumerate(records):
            if rec[0] == NONE or int(phases[rec[0], 1]) not in match:
                continue
            mu, lam = float(params[c, 1]), float(params[c, 2])
            lame = lam - mu
            young = 2 * mu * (1 + lame / (2 * (lame + mu)))
            r = rows[int(phases[rec[0], 1])]
            out.append(Target(k, int(self._row_env[r]), c, (mu, lam, young, 0.0), (young,), int(self._row_entity[r])))
        if not out:
            raise RandomizationError(f"{term.where}: youngs_modulus: '{term.entity}' has no elastic tets "
                                     "(a SoftBody with tets and youngs_modulus)")
        return "tets", out

    def _rows_renderables(self, k: int, term: Term):
        if "render.renderables" not in self._keys:
            raise self._fail_none(term, "renderable", [])
        data = self._read("render.renderables", RENDERABLE_WORDS)
        ids = data.view(np.uint32)[:, 0:4]
        rows = [int(i[0]) for i in ids]
        match = set(self._matching(term, rows))
        if not match:
            raise self._fail_none(term, "renderable", rows)
        if term.param == "texture":  # indices of textures there are
            infos = self._read("render.textures", 4, np.uint32)
            count = int((infos[:, 1] > 0).sum())
            if max(term.choices) >= count:
                raise RandomizationError(f"{term.where}: texture: the world has {count} texture(s) (indices 0 to "
                                         f"{count - 1}, -1 none), got choices {list(term.choices)}")
        return "renderables", [Target(k, int(self._row_env[r]), i, tuple(data[i, 4:8]), tuple(data[i, 4:7]),
                                      int(self._row_entity[r])) for i, r in enumerate(rows) if r in match]

    def _rows_lights(self, k: int, term: Term):
        data = (self._read("render.lights", LIGHT_WORDS) if "render.lights" in self._keys
                else np.zeros((0, LIGHT_WORDS), np.float32))
        ids = data.view(np.uint32)[:, 0:4]
        rows = [int(i[0]) if i[1] != 0 and i[0] != NONE else -1 for i in ids]
        match = set(self._matching(term, [r for r in rows if r >= 0]))
        if not match:
            raise self._fail_none(term, "light", [r for r in rows if r >= 0])
        out = []
        for i, r in enumerate(rows):
            if r in match:
                light = self._world.entity(int(self._row_entity[r])).light
                nominal = (*light.color, light.intensity)
                acted = (light.intensity,) if term.param == "light_intensity" else tuple(light.color)
                out.append(Target(k, int(self._row_env[r]), i, nominal, acted, int(self._row_entity[r])))
        return "lights", out

    def _camera_rows(self, term: Term, need_depth: bool = False):
        cams = self.engine.cameras
        rows = [int(self._entity_row[e]) for e in cams["entity"]]
        match = [(i, r) for i, r in enumerate(rows) if fnmatch.fnmatchcase(self._names[r], term.entity)]
        if not match:
            raise self._fail_none(term, "camera", rows)
        if need_depth:
            for i, r in match:
                if f"camera{int(cams['group'][i])}.depth" not in self._keys:
                    raise RandomizationError(f"{term.where}: depth_noise: camera '{self._names[r]}' renders no depth "
                                             "(add 'depth' to its products)")
        return cams, match

    def _rows_transforms(self, k: int, term: Term):
        _, match = self._camera_rows(term)
        key = "transform.initial_positions" if term.param == "camera_position" else "transform.initial_rotations"
        start = self._read(key, 4)
        out = []
        for _, r in match:
            ent = self._world.entity(int(self._row_entity[r]))
            if ent.has(cressim.RigidBody):
                raise RandomizationError(f"{term.where}: {term.param}: camera '{ent.name}' rides a rigid body, which "
                                         "sets its pose every step; randomize a camera without one")
            out.append(Target(k, int(self._row_env[r]), r, tuple(start[r]), tuple(start[r, :3]),
                              int(self._row_entity[r])))
        return "transforms", out

    def _rows_depth(self, k: int, term: Term):
        cams, match = self._camera_rows(term, need_depth=True)
        return "depth", [Target(k, int(self._row_env[r]), i, (0, 0, 0, 0), (0.0,), int(self._row_entity[r]))
                         for i, r in match]

    def _rows_probes(self, k: int, term: Term):
        out, rows_all, g = {}, [], 0
        while f"ultrasound{g}.probes" in self._keys:
            key = f"ultrasound{g}.probes"
            data = self._read(key, self.engine.buffer(key).shape[1])  # UltrasoundProbeData: display.y at word 21
            for i, rec in enumerate(data):
                r = int(rec[0:1].view(np.uint32)[0])
                rows_all.append(r)
                if fnmatch.fnmatchcase(self._names[r], term.entity):
                    out.setdefault(g, []).append(Target(k, int(self._row_env[r]), i, (float(rec[21]), 0, 0, 0),
                                                        (float(rec[21]),), int(self._row_entity[r]), g))
            g += 1
        if not out:
            raise self._fail_none(term, "ultrasound probe", rows_all)
        # one kind per probe group: each group's probes are their own buffer
        return "probes", [t for group in sorted(out) for t in out[group]]

    # --- GPU resources -----------------------------------------------------------------------
    def _create_buffers(self):
        e, n, T, D = self.engine, self.num_envs, len(self.terms), self.column_count
        terms = np.zeros((T, 4), np.uint32)
        columns = np.zeros((D, 4), np.float32)
        choices = []
        for k, t in enumerate(self.terms):
            c = self._columns[t.name]
            terms[k] = (c.start, t.spec.size, DISTRIBUTION_CODES[t.distribution] | WHEN_CODES[t.when] << 8, t.every)
            clip = t.clip or ((-np.inf,) * t.spec.size, (np.inf,) * t.spec.size)
            for j in range(t.spec.size):
                columns[c.start + j] = (t.low[j], t.high[j], clip[0][j], clip[1][j])
            if t.choices:  # x: first, y: count (exact in float32 far beyond any list here)
                columns[c.start] = (len(choices), len(t.choices), 0, 0)
                choices += t.choices
        self._choices = e.create_shared_buffer("randomization_choices", max(len(choices), 1), "float32")
        self._choices.write(np.array(choices or [0.0], np.float32))
        self._terms = e.create_shared_buffer("randomization_terms", (T, 4), "uint32")
        self._terms.write(terms)
        self._column_table = e.create_shared_buffer("randomization_columns", (D, 4), "float32")
        self._column_table.write(columns)
        self.values = e.create_shared_buffer("randomization_values", (n, D), "float32")
        self.values.write(np.zeros((n, D), np.float32))
        self._state = {}
        for name in ("fresh", "draws", "counters"):
            self._state[name] = e.create_shared_buffer(f"randomization_{name}", (n, T), "uint32")
            self._state[name].write(np.zeros((n, T), np.uint32))
        self._state["frame"] = e.create_shared_buffer("randomization_frame", 1, "uint32")
        self._state["frame"].write(np.zeros(1, np.uint32))

    def _constants(self, **extra) -> dict:
        return {"envs": self.num_envs, "terms": len(self.terms), "columns": self.column_count, "seed": self.seed,
                "env_offset": self.env_offset, "reset_all": 0, "items": 0, "pixels": 1, **extra}

    def _pass(self, entry: str, threads: int, bindings: dict, writes=(), **constants):
        common = {"terms": self._terms, "values": self.values, "fresh": self._state["fresh"]}
        return self.engine.create_compute_pass(
            HLSL.read_text(), name=str(HLSL), entry=entry, threads=max(threads, 1),
            bindings={**common, **bindings}, constants=self._constants(**constants), internal_writes=list(writes))

    def _table(self, name: str, rows: list[Target]):
        ids = np.array([(t.term, t.env, t.row, self.terms[t.term].spec.code
                         | OPERATION_CODES[self.terms[t.term].operation] << 8) for t in rows], np.uint32)
        ids_buffer = self.engine.create_shared_buffer(f"randomization_{name}_ids", (len(rows), 4), "uint32")
        ids_buffer.write(ids)
        nominal = self.engine.create_shared_buffer(f"randomization_{name}_nominal", (len(rows), 4), "float32")
        nominal.write(np.array([t.nominal for t in rows], np.float32))
        return {"target_ids": ids_buffer, "target_nominal": nominal}

    def _create_passes(self):
        sample = {"columns": self._column_table, "choices": self._choices, "reset_mask": "env.reset_mask", "ended_a": self._episode_flags[0],
                  "ended_b": self._episode_flags[1], "draws": self._state["draws"],
                  "counters": self._state["counters"], "frame": self._state["frame"]}
        self._sample = {flag: self._pass("sample", self.num_envs, sample, reset_all=int(flag))
                        for flag in (False, True)}
        outputs = {"bodies": {"bodies": "rigid.bodies"}, "colliders": {"colliders": "rigid.colliders"},
                   "joints": {"joints": "joint.model"}, "objects": {"objects": "particles.objects"},
                   "particles": {"particle_positions": "particles.positions"},
                   "tets": {"tet_constraints": "particles.tet_constraints",
                            "tet_initial_constraints": "particles.tet_initial_constraints"},
                   "renderables": {"renderables": "render.renderables"}, "lights": {"lights": "render.lights"},
                   "transforms": {"positions": "transform.positions", "rotations": "transform.rotations"}}
        self._apply, self._noise = [], []
        if "particles.tet_initial_constraints" not in self._keys:  # no heat: no authored copy to keep
            del outputs["tets"]["tet_initial_constraints"]
        for kind, rows in self._targets.items():
            if kind in outputs:
                entry = "apply_tets_heated" if kind == "tets" and len(outputs[kind]) == 2 else "apply_" + kind
                self._apply.append(self._pass(entry, len(rows), {**outputs[kind], **self._table(kind, rows)},
                                              outputs[kind].values(), items=len(rows)))
            elif kind == "constraints":
                for g, family in enumerate(COMPLIANCES):
                    group = [t for t in rows if t.group == g]
                    if group:
                        key = f"particles.{family}_constraints"
                        self._apply.append(self._pass("apply_constraints", len(group),
                                                      {"family_constraints": key, **self._table(family, group)},
                                                      [key], items=len(group)))
            elif kind == "probes":
                for g in sorted({t.group for t in rows}):
                    group = [t for t in rows if t.group == g]
                    key = f"ultrasound{g}.probes"
                    self._apply.append(self._pass("apply_probes", len(group),
                                                  {"probes": key, **self._table(f"probes{g}", group)}, [key],
                                                  items=len(group)))
            elif kind == "depth":
                self._create_noise(rows)

    def _create_noise(self, rows: list[Target]):
        cams = self.engine.cameras
        for g in sorted({int(cams["group"][t.row]) for t in rows}):
            key = f"camera{g}.depth"
            layers, height, width = self.engine.buffer(key).shape
            table = np.zeros((layers, 2), np.uint32)
            for i in np.flatnonzero(np.asarray(cams["group"]) == g):
                table[int(cams["layer"][i]), 0] = int(cams["env"][i])
            for t in rows:
                if int(cams["group"][t.row]) == g:
                    table[int(cams["layer"][t.row]), 1] = self._columns[self.terms[t.term].name].start + 1
            buffer = self.engine.create_shared_buffer(f"randomization_depth{g}_layers", (layers, 2), "uint32")
            buffer.write(table)
            items = layers * height * width
            self._noise.append(self._pass("depth_noise", items, {"layer_columns": buffer, "depth": key,
                                                                 "frame": self._state["frame"]}, [key],
                                          items=items, pixels=height * width))

    def _all_passes(self):
        return [*self._sample.values(), *self._apply, *self._noise]

