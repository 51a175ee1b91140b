"""Where each randomization term writes: its rows in the engine's model buffers, found once by
entity name, with the authored values the draws act on; checked (one writer per field, every
reachable value allowed). Set-up work is numpy over the rows (a million tets resolve in a second)."""
from __future__ import annotations

import fnmatch
from dataclasses import dataclass

import numpy as np

import cressim

from .config import INF, RandomizationError, Term

NONE = 0xFFFFFFFF
# words of the model structs (shaders/common/*.h)
BODY_WORDS, COLLIDER_WORDS, JOINT_WORDS, OBJECT_WORDS = 12, 20, 28, 36
RENDERABLE_WORDS, LIGHT_WORDS, CONSTRAINT_WORDS = 16, 16, 8
# XPBD constraint families and which of params.x, params.y hold compliances (stretch_shear has none)
COMPLIANCES = {"distance": (0, 1), "volume": (0, 1), "bend": (0, 1), "stretch": (0, 1), "bend_twist": (1, 1)}


@dataclass
class Rows:
    """The rows one term writes in one buffer (`kind`, and `group`: which probe group or
    constraint family): per row its env, index, entity, the authored values (nominal, 4 floats,
    what randomize.hlsl reads) and the authored scalars the operation acts on (for the check)."""

    term: int
    kind: str
    env: np.ndarray
    row: np.ndarray
    entity: np.ndarray
    nominal: np.ndarray
    acted_on: np.ndarray
    group: int = 0


class Targets:
    """Resolves terms against an uploaded engine."""

    def __init__(self, engine: cressim.Engine):
        self.engine, self.world = engine, engine.world
        m = engine.mapping
        self.row_entity = np.asarray(m["entity_id"]).astype(np.int64)
        self.row_env = np.asarray(m["env_index"]).astype(np.int64)
        self.entity_row = np.asarray(m["entity_row"]).astype(np.int64)
        names = [self.world.entity(int(e)).name for e in self.row_entity]
        self.names = sorted(set(names))
        self.row_name = np.searchsorted(self.names, names)  # name index per row
        self.keys = set(engine.internal_keys)
        self._owners = None

    def resolve(self, terms: list[Term]) -> list[Rows]:
        out, written = [], {}
        for k, term in enumerate(terms):
            for rows in getattr(self, "_" + term.spec.kind)(k, term):
                field = (rows.kind, rows.group, "light" if term.param.startswith("light_") else term.param)
                for other, where in written.get(field, []):
                    both = np.intersect1d(other, rows.row)
                    if len(both):
                        i = int(np.flatnonzero(rows.row == both[0])[0])
                        raise RandomizationError(f"{term.where}: {term.param} of '{self._name(rows, i)}' in env "
                                                 f"{rows.env[i]} is already randomized by {where}")
                written.setdefault(field, []).append((rows.row, term.where))
                self._check_range(term, rows)
                out.append(rows)
        return out

    # --- helpers -----------------------------------------------------------------------------
    def _name(self, rows: Rows, i: int) -> str:
        return self.world.entity(int(rows.entity[i])).name

    def _read(self, key: str, words: int, dtype=np.float32) -> np.ndarray:
        return np.ascontiguousarray(self.engine.buffer(key).read()).view(dtype).reshape(-1, words)

    def _match(self, term: Term, entity_rows: np.ndarray) -> np.ndarray:
        """Which of these entity rows the term's name pattern matches."""
        ok = [i for i, n in enumerate(self.names) if fnmatch.fnmatchcase(n, term.entity)]
        return np.isin(self.row_name[np.asarray(entity_rows, np.int64)], ok)

    def _none(self, term: Term, what: str, entity_rows) -> RandomizationError:
        have = sorted({self.names[i] for i in self.row_name[np.asarray(entity_rows, np.int64)]} - {""})
        return RandomizationError(f"{term.where}: {term.param}: no {what} named '{term.entity}' "
                                  f"(entities with one: {', '.join(have) or 'none'})")

    def _rows(self, k: int, kind: str, entity_rows, rows, nominal, acted_on, group: int = 0) -> Rows:
        r = np.asarray(entity_rows, np.int64)
        return Rows(k, kind, self.row_env[r], np.asarray(rows, np.int64), self.row_entity[r],
                    np.asarray(nominal, np.float32).reshape(-1, 4), np.asarray(acted_on, np.float64).reshape(len(r), -1),
                    group)

    def _check_range(self, term: Term, rows: Rows) -> None:
        spec = term.spec
        if spec.low == -INF and spec.high == INF:
            return
        lows, highs = (np.array(b, np.float64) for b in term.bounds())
        n = rows.acted_on[:, :, None]  # (rows, acted, components)
        with np.errstate(invalid="ignore", over="ignore"):
            if term.operation == "scale":  # an authored 0 stays 0 whatever the draw
                ends = (np.where(n == 0, 0.0, n * lows), np.where(n == 0, 0.0, n * highs))
            elif term.operation == "add":
                ends = (n + lows, n + highs)
            else:
                ends = (lows + 0 * n, highs + 0 * n)
        a, b = np.minimum(*ends), np.maximum(*ends)
        bad = (a <= spec.low if spec.open_low else a < spec.low) | (b > spec.high) | np.isnan(a) | np.isnan(b)
        if bad.any():
            i, j, c = np.argwhere(bad)[0]
            domain = f"{'(' if spec.open_low else '['}{spec.low:g}, {spec.high:g}]"
            hint = " (a gaussian needs clip: [low, high] here)" if term.distribution == "gaussian" and term.clip is None \
                else ""
            unit = f" {spec.unit}" if spec.unit else ""
            raise RandomizationError(
                f"{term.where}: {term.param} of '{self._name(rows, i)}' (env {rows.env[i]}, authored "
                f"{rows.acted_on[i, j]:g}{unit}) would reach [{a[i, j, c]:g}, {b[i, j, c]:g}] with operation "
                f"{term.operation}; it must stay in {domain}{hint}")

    def _objects(self) -> np.ndarray:
        if "particles.objects" not in self.keys:
            return np.zeros((0, OBJECT_WORDS), np.uint32)
        return self._read("particles.objects", OBJECT_WORDS, np.uint32)

    def _object_match(self, term: Term) -> tuple[np.ndarray, np.ndarray]:
        """(entity row of each particle object, which match the term)."""
        rows = self._objects()[:, 4].astype(np.int64)
        return rows, self._match(term, rows)

    # --- one method a kind: the rows of a term -----------------------------------------------
    def _bodies(self, k: int, term: Term) -> list[Rows]:
        if "rigid.bodies" in self.keys:
            body_entity = np.asarray(self.engine.buffer("rigid.body_entity").read()).ravel().astype(np.int64)
            bodies = self._read("rigid.bodies", BODY_WORDS)
        else:
            body_entity, bodies = np.zeros(0, np.int64), np.zeros((0, BODY_WORDS), np.float32)
        body_rows = self.entity_row[body_entity]
        match = np.flatnonzero(self._match(term, body_rows))
        if not len(match):
            object_rows, objects = self._object_match(term)
            if objects.any():  # a particle object's
                return self._particles(k, term) if term.param == "mass" else self._objects_of(k, term)
            raise self._none(term, "rigid body or particle object", np.concatenate([body_rows, object_rows]))
        r = body_rows[match]
        if term.param == "mass":
            inv = bodies[match, 0:4]
            kinematic = np.flatnonzero(~(inv[:, 3] > 0))
            if len(kinematic):
                i = kinematic[0]
                raise RandomizationError(f"{term.where}: mass: '{self.names[self.row_name[r[i]]]}' (env "
                                         f"{self.row_env[r[i]]}) is kinematic; only dynamic bodies have a mass")
            return [self._rows(k, "bodies", r, match, inv, 1.0 / inv[:, 3])]
        damping = bodies[match, 4:8]
        return [self._rows(k, "bodies", r, match, damping, damping[:, :2])]

    def _colliders(self, k: int, term: Term) -> list[Rows]:
        if self._owners is None:  # stored env by env, row by row, a record per shape (rigid_model.cpp)
            owners = []
            if "rigid.colliders" in self.keys:
                for r, e in enumerate(self.row_entity):
                    ent = self.world.entity(int(e))
                    if ent.has(cressim.Collider):
                        owners += [r] * len(ent.collider.shapes)
            self._owners = np.array(owners, np.int64)
        owners = self._owners
        match = np.flatnonzero(self._match(term, owners))
        if not len(match):
            object_rows, objects = self._object_match(term)
            if term.param == "friction" and objects.any():
                return self._objects_of(k, term)
            what = "collider or particle object" if term.param == "friction" else "collider"
            raise self._none(term, what, np.concatenate([owners, object_rows if term.param == "friction" else []]))
        material = self._read("rigid.colliders", COLLIDER_WORDS)[:, 12:16]
        if len(material) != len(owners):
            raise RuntimeError(f"randomization: {len(owners)} collider shapes in the world, {len(material)} "
                               "in rigid.colliders")
        acted = material[match, :2] if term.param == "friction" else material[match, 2:3]
        return [self._rows(k, "colliders", owners[match], match, material[match], acted)]

    def _joints(self, k: int, term: Term) -> list[Rows]:
        entity = (np.asarray(self.engine.buffer("joint.entity").read()).ravel().astype(np.int64)
                  if "joint.model" in self.keys else np.zeros(0, np.int64))
        rows = self.entity_row[entity]
        match = np.flatnonzero(self._match(term, rows))
        if not len(match):
            raise self._none(term, "joint", rows)
        drive = self._read("joint.model", JOINT_WORDS)[match, 20:24]
        i = 0 if term.param == "joint_stiffness" else 1
        return [self._rows(k, "joints", rows[match], match, drive, drive[:, i])]

    def _objects_of(self, k: int, term: Term) -> list[Rows]:
        """A particle object's friction or damping (ParticleObject.material)."""
        objects = self._objects()
        rows, match = objects[:, 4].astype(np.int64), None
        match = np.flatnonzero(self._match(term, rows))
        material = objects[match, 8:12].view(np.float32)
        i = 1 if term.param == "friction" else 2
        return [self._rows(k, "objects", rows[match], match, material, material[:, i])]

    def _particles(self, k: int, term: Term) -> list[Rows]:
        """A particle object's mass: every free particle's (inverse mass w > 0) scaled alike."""
        object_rows, match = self._object_match(term)
        owner = self._read("particles.phases", 4, np.uint32)[:, 1].astype(np.int64)
        w = self._read("particles.initial_positions", 4)[:, 3].astype(np.float64)
        free = np.flatnonzero((w > 0) & match[owner])
        if not len(free):
            raise RandomizationError(f"{term.where}: mass: '{term.entity}' has no free particles (all fixed)")
        total = np.bincount(owner[free], weights=1.0 / w[free], minlength=len(object_rows))
        nominal = np.zeros((len(free), 4))
        nominal[:, 0], nominal[:, 1] = w[free], total[owner[free]]
        return [self._rows(k, "particles", object_rows[owner[free]], free, nominal, total[owner[free]])]

    def _first_particles(self, records: np.ndarray, count: int) -> np.ndarray:
        """Each record's first particle (a frame id, >= count, stands for its segment's first)."""
        first = np.where(records[:, 0] != NONE, records[:, 0], records[:, 1]).astype(np.int64)
        frames = first >= count
        if frames.any():
            edges = np.asarray(self.engine.buffer("particles.edge_particles").read()).ravel().astype(np.int64)
            first[frames] = edges[first[frames] - count]
        return first

    def _constraints(self, k: int, term: Term) -> list[Rows]:
        """The object's records of every XPBD family (a pass a family: group = its index)."""
        object_rows, match = self._object_match(term)
        if not match.any():
            raise self._none(term, "particle object", object_rows)
        owner = self._read("particles.phases", 4, np.uint32)[:, 1].astype(np.int64)
        out = []
        for g, (family, fields) in enumerate(COMPLIANCES.items()):
            key = f"particles.{family}_constraints"
            if key not in self.keys or not self.engine.buffer(key).shape[0]:
                continue
            records = self._read(key, CONSTRAINT_WORDS, np.uint32)
            obj = owner[self._first_particles(records, len(owner))]
            rows = np.flatnonzero(match[obj])
            if len(rows):
                nominal = np.zeros((len(rows), 4))
                nominal[:, :2] = records[rows, 4:6].view(np.float32)
                nominal[:, 2:] = fields
                out.append(self._rows(k, "constraints", object_rows[obj[rows]], rows, nominal, np.ones(len(rows)), g))
        if not out:
            raise RandomizationError(f"{term.where}: stiffness: '{term.entity}' has no XPBD constraints (an elastic "
                                     "tet body's stiffness is its youngs_modulus)")
        return out

    def _tets(self, k: int, term: Term) -> list[Rows]:
        object_rows, match = self._object_match(term)
        if not match.any() or "particles.tet_constraints" not in self.keys:
            raise self._none(term, "soft body (particle object)", object_rows)
        records = self._read("particles.tet_constraints", CONSTRAINT_WORDS, np.uint32)
        owner = self._read("particles.phases", 4, np.uint32)[:, 1].astype(np.int64)
        real = records[:, 0] != NONE
        obj = np.where(real, owner[np.where(real, records[:, 0], 0).astype(np.int64)], -1)
        rows = np.flatnonzero(real & match[np.maximum(obj, 0)])
        if not len(rows):
            raise RandomizationError(f"{term.where}: youngs_modulus: '{term.entity}' has no elastic tets "
                                     "(a SoftBody with tets and youngs_modulus)")
        params = records[rows, 4:8].view(np.float32).astype(np.float64)
        mu, lam = params[:, 1], params[:, 2]
        lame = lam - mu  # lambda stored as Lame's lambda + mu (particle_model.cpp)
        young = 2 * mu * (1 + lame / (2 * (lame + mu)))
        nominal = np.stack([mu, lam, young, np.zeros_like(mu)], 1)
        return [self._rows(k, "tets", object_rows[obj[rows]], rows, nominal, young)]

    def _renderables(self, k: int, term: Term) -> list[Rows]:
        if "render.renderables" not in self.keys:
            raise self._none(term, "renderable", [])
        data = self._read("render.renderables", RENDERABLE_WORDS)
        rows = data.view(np.uint32)[:, 0].astype(np.int64)
        match = np.flatnonzero(self._match(term, rows))
        if not len(match):
            raise self._none(term, "renderable", rows)
        if term.param == "texture":  # indices of textures there are
            count = int((self._read("render.textures", 4, np.uint32)[:, 1] > 0).sum())
            if max(term.choices) >= count:
                raise RandomizationError(f"{term.where}: texture: the world has {count} texture(s) (indices 0 to "
                                         f"{count - 1}, -1 none), got choices {list(term.choices)}")
        return [self._rows(k, "renderables", rows[match], match, data[match, 4:8], data[match, 4:7])]

    def _lights(self, k: int, term: Term) -> list[Rows]:
        ids = (self._read("render.lights", LIGHT_WORDS, np.uint32)[:, 0:4] if "render.lights" in self.keys
               else np.zeros((0, 4), np.uint32))
        slots = np.flatnonzero((ids[:, 1] != 0) & (ids[:, 0] != NONE))  # entity lights
        rows = ids[slots, 0].astype(np.int64)
        match = np.flatnonzero(self._match(term, rows))
        if not len(match):
            raise self._none(term, "light", rows)
        lights = [self.world.entity(int(self.row_entity[r])).light for r in rows[match]]
        nominal = [(*light.color, light.intensity) for light in lights]
        acted = [(light.intensity,) if term.param == "light_intensity" else tuple(light.color) for light in lights]
        return [self._rows(k, "lights", rows[match], slots[match], nominal, acted)]

    def _environment(self, k: int, term: Term) -> list[Rows]:
        """The ambient light of each env with a matching light or environment entity: its sky,
        ground and environment map scale (rows 3 env + 0, 1, 2 of render.env_lighting's colours)."""
        if "render.env_lighting" not in self.keys:
            raise self._none(term, "light or environment", [])
        lit = np.array([r for r, e in enumerate(self.row_entity)
                        if self.world.entity(int(e)).has(cressim.Light)
                        or self.world.entity(int(e)).has(cressim.EnvironmentLight)], np.int64)
        match = lit[self._match(term, lit)] if len(lit) else lit
        if not len(match):
            raise self._none(term, "light or environment", lit)
        _, first = np.unique(self.row_env[match], return_index=True)  # one an env
        rows = match[first]
        lighting = self._read("render.env_lighting", self.engine.buffer("render.env_lighting").shape[1])
        envs = self.row_env[rows]
        colours = np.stack([lighting[envs, 0:4], lighting[envs, 4:8], lighting[envs, 20:24]], 1)  # sky, ground, map
        return [self._rows(k, "environment", np.repeat(rows, 3), (3 * envs[:, None] + np.arange(3)).ravel(),
                           colours.reshape(-1, 4), np.ones(3 * len(rows)))]

    def _cameras(self, term: Term, need_depth: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """(camera indices of engine.cameras, their entity rows) that the term names."""
        cams = self.engine.cameras
        rows = self.entity_row[np.asarray(cams["entity"], np.int64)]
        match = np.flatnonzero(self._match(term, rows))
        if not len(match):
            raise self._none(term, "camera", rows)
        for i in match:
            if need_depth and f"camera{int(cams['group'][i])}.depth" not in self.keys:
                raise RandomizationError(f"{term.where}: depth_noise: camera '{self.names[self.row_name[rows[i]]]}' "
                                         "renders no depth (add 'depth' to its products)")
        return match, rows[match]

    def _transforms(self, k: int, term: Term) -> list[Rows]:
        _, rows = self._cameras(term)
        for r in rows:
            ent = self.world.entity(int(self.row_entity[r]))
            if ent.has(cressim.RigidBody):
                raise RandomizationError(f"{term.where}: {term.param}: camera '{ent.name}' rides a rigid body, which "
                                         "sets its pose every step; randomize a camera without one")
        key = "transform.initial_positions" if term.param == "camera_position" else "transform.initial_rotations"
        start = self._read(key, 4)[rows]
        return [self._rows(k, "transforms", rows, rows, start, start[:, :3])]

    def _depth(self, k: int, term: Term) -> list[Rows]:
        cameras, rows = self._cameras(term, need_depth=True)
        return [self._rows(k, "depth", rows, cameras, np.zeros((len(rows), 4)), np.zeros(len(rows)))]

    def _probes(self, k: int, term: Term) -> list[Rows]:
        out, seen, g = [], [], 0
        while f"ultrasound{g}.probes" in self.keys:  # one buffer a probe group
            key = f"ultrasound{g}.probes"
            data = self._read(key, self.engine.buffer(key).shape[1])  # UltrasoundProbeData: display.y at word 21
            rows = data.view(np.uint32)[:, 0].astype(np.int64)
            seen.append(rows)
            match = np.flatnonzero(self._match(term, rows))
            if len(match):
                gain = data[match, 21]
                nominal = np.zeros((len(match), 4))
                nominal[:, 0] = gain
                out.append(self._rows(k, "probes", rows[match], match, nominal, gain, g))
            g += 1
        if not out:
            raise self._none(term, "ultrasound probe", np.concatenate(seen) if seen else [])
        return out
