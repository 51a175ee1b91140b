"""The Randomizer: a config's terms resolved to rows of the engine's buffers once (targets.py),
then recorded as compute passes into each frame (randomize.hlsl): host work per step is O(1) in
envs.

A frame with randomization (VectorEnv does this)::

    r.sample(reset_all)      # before reset_flagged_envs: sees env.reset_mask; draws
    engine.reset_flagged_envs()
    r.apply()                # writes the draws into bodies, colliders, ... (after the reset,
                             # which puts camera transforms back)
    ... sensors ...
    r.after_sensors()        # depth noise, before anything reads the images
"""
from __future__ import annotations

import zlib
from pathlib import Path

import numpy as np

import cressim

from .config import RandomizationError, Term, load_terms
from .targets import COMPLIANCES, Rows, Targets

HLSL = Path(__file__).with_name("randomize.hlsl")
DISTRIBUTION_CODES = {"uniform": 0, "log_uniform": 1, "gaussian": 2, "choice": 3}
OPERATION_CODES = {"scale": 0, "add": 1, "abs": 2}
WHEN_CODES = {"reset": 0, "interval": 1}
# the buffers each kind of target writes: HLSL name -> engine key
OUTPUTS = {"bodies": {"bodies": "rigid.bodies"}, "colliders": {"colliders": "rigid.colliders"},
           "joints": {"joints": "joint.model"}, "objects": {"objects": "particles.objects"},
           "particles": {"particle_positions": "particles.positions"},
           "tets": {"tet_constraints": "particles.tet_constraints"},
           "renderables": {"renderables": "render.renderables"}, "lights": {"lights": "render.lights"},
           "environment": {"env_lighting": "render.env_lighting"},
           "transforms": {"positions": "transform.positions", "rotations": "transform.rotations"}}


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
        self._keys = set(engine.internal_keys)
        # value columns: each term's components side by side
        self._columns, first = {}, 0
        for t in self.terms:
            self._columns[t.name] = slice(first, first + t.spec.size)
            first += t.spec.size
        self.column_count = first
        self._targets: list[Rows] = Targets(engine).resolve(self.terms)
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

    def reset_envs(self, envs) -> None:
        """engine.reset_envs(envs) with a draw: the engine resets them at the next frame's start,
        before any pass runs, so the sampler is told here (host work O(envs), on request only)."""
        flags = np.zeros(self.num_envs, np.uint32)
        flags[np.asarray(envs, np.int64)] = 1
        self.engine.reset_envs([int(e) for e in envs])
        self._state["pending"].write(flags)

    @property
    def sensor_noise(self) -> bool:
        """Whether after_sensors() records anything (depth noise): call it right after the cameras
        render, once per render (the noise goes onto the image in place)."""
        return bool(self._noise)

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
        return [(int(e), int(i)) for rows in self._targets if rows.term == k for e, i in zip(rows.env, rows.entity)]

    # --- GPU resources -----------------------------------------------------------------------
    def _create_buffers(self):
        e, n, T, D = self.engine, self.num_envs, len(self.terms), self.column_count
        terms = np.zeros((T, 8), np.uint32)  # randomize.hlsl's Term
        columns = np.zeros((D, 4), np.float32)
        choices = []
        for k, t in enumerate(self.terms):
            c = self._columns[t.name]
            terms[k, :5] = (c.start, t.spec.size, DISTRIBUTION_CODES[t.distribution] | WHEN_CODES[t.when] << 8,
                            t.every, zlib.crc32(t.name.encode()))
            clip = t.clip or ((-np.inf,) * t.spec.size, (np.inf,) * t.spec.size)
            for j in range(t.spec.size):
                columns[c.start + j] = (t.low[j], t.high[j], clip[0][j], clip[1][j])
            if t.choices:  # x: first, y: count (exact in float32 far beyond any list here)
                columns[c.start] = (len(choices), len(t.choices), 0, 0)
                choices += t.choices
        self._choices = e.create_shared_buffer("randomization_choices", max(len(choices), 1), "float32")
        self._choices.write(np.array(choices or [0.0], np.float32))
        self._terms = e.create_shared_buffer("randomization_terms", (T, 8), "uint32")
        self._terms.write(terms)
        self._column_table = e.create_shared_buffer("randomization_columns", (D, 4), "float32")
        self._column_table.write(columns)
        self.values = e.create_shared_buffer("randomization_values", (n, D), "float32")
        self.values.write(np.zeros((n, D), np.float32))
        self._state = {}
        for name in ("fresh", "draws", "counters"):
            self._state[name] = e.create_shared_buffer(f"randomization_{name}", (n, T), "uint32")
            self._state[name].write(np.zeros((n, T), np.uint32))
        self._state["pending"] = e.create_shared_buffer("randomization_pending", n, "uint32")
        self._state["pending"].write(np.zeros(n, np.uint32))
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

    def _table(self, name: str, rows: Rows):
        term = self.terms[rows.term]
        code = term.spec.code | OPERATION_CODES[term.operation] << 8
        ids = np.stack([np.full(len(rows.row), rows.term), rows.env, rows.row, np.full(len(rows.row), code)], 1)
        ids_buffer = self.engine.create_shared_buffer(f"randomization_{name}_ids", (len(ids), 4), "uint32")
        ids_buffer.write(ids.astype(np.uint32))
        nominal = self.engine.create_shared_buffer(f"randomization_{name}_nominal", (len(ids), 4), "float32")
        nominal.write(rows.nominal)
        return {"target_ids": ids_buffer, "target_nominal": nominal}

    def _create_passes(self):
        sample = {"columns": self._column_table, "choices": self._choices, "reset_mask": "env.reset_mask",
                  "ended_a": self._episode_flags[0], "ended_b": self._episode_flags[1], "draws": self._state["draws"],
                  "counters": self._state["counters"], "frame": self._state["frame"], "pending": self._state["pending"]}
        self._sample = {flag: self._pass("sample", self.num_envs, sample, reset_all=int(flag))
                        for flag in (False, True)}
        self._apply, self._noise = [], []
        heated = "particles.tet_initial_constraints" in self._keys  # heat keeps an authored copy, kept in step
        for n, rows in enumerate(self._targets):  # a pass a term and buffer
            name = f"{n}_{rows.kind}"
            if rows.kind in OUTPUTS:
                outputs = dict(OUTPUTS[rows.kind])
                entry = "apply_" + rows.kind
                if rows.kind == "tets" and heated:
                    outputs["tet_initial_constraints"] = "particles.tet_initial_constraints"
                    entry = "apply_tets_heated"
            elif rows.kind == "constraints":
                outputs, entry = {"family_constraints": f"particles.{list(COMPLIANCES)[rows.group]}_constraints"}, \
                    "apply_constraints"
            elif rows.kind == "probes":
                outputs, entry = {"probes": f"ultrasound{rows.group}.probes"}, "apply_probes"
            else:  # depth noise: after the sensors
                self._create_noise(rows)
                continue
            self._apply.append(self._pass(entry, len(rows.row), {**outputs, **self._table(name, rows)},
                                          outputs.values(), items=len(rows.row)))

    def _create_noise(self, rows: Rows):
        cams = self.engine.cameras
        column = self._columns[self.terms[rows.term].name].start
        for g in sorted({int(cams["group"][c]) for c in rows.row}):
            key = f"camera{g}.depth"
            layers, height, width = self.engine.buffer(key).shape
            table = np.zeros((layers, 2), np.uint32)
            for i in np.flatnonzero(np.asarray(cams["group"]) == g):
                table[int(cams["layer"][i]), 0] = int(cams["env"][i])
            for c in rows.row:
                if int(cams["group"][c]) == g:
                    table[int(cams["layer"][c]), 1] = column + 1
            buffer = self.engine.create_shared_buffer(f"randomization_depth{rows.term}_{g}_layers", (layers, 2),
                                                      "uint32")
            buffer.write(table)
            items = layers * height * width
            self._noise.append(self._pass("depth_noise", items, {"layer_columns": buffer, "depth": key,
                                                                 "frame": self._state["frame"]}, [key],
                                          items=items, pixels=height * width))

    def _all_passes(self):
        return [*self._sample.values(), *self._apply, *self._noise]
