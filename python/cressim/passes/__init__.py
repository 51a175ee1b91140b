"""Ready-made custom compute passes (HLSL sources for Engine.create_compute_pass) and the tools
built on them: `grasp.Grasp` (jaws that hold soft bodies and threads), `suction.Suction` (a tip
that removes fluid), `cautery.Cautery` (an energized tip that heats tissue)."""
from pathlib import Path

import numpy as np


def source(name: str) -> str:
    """The HLSL of pass `name` ("grasp", "suction", "cautery")."""
    path = Path(__file__).with_name(f"{name}.hlsl")
    if not path.exists():
        known = sorted(p.stem for p in Path(__file__).parent.glob("*.hlsl"))
        raise ValueError(f"no built-in pass '{name}'; known: {', '.join(known)}")
    return path.read_text()


class EnvTool:
    """What a per-env tool pass shares (Grasp, Suction, Cautery): `commands`, int32 (envs, 4) on the GPU,
    x the command (1 on / closed, 0 off / open), y the rigid body (-1: none), z the pass's state,
    w its count; a task pass may write x itself, the host through `set`."""

    def __init__(self, engine, name: str, bodies):
        self.engine = engine
        self.envs = engine.buffer("particles.env_ranges").shape[0]
        self.commands = engine.create_shared_buffer(f"{name}_commands", (self.envs, 4), "int32")
        state = np.zeros((self.envs, 4), np.int32)
        state[:, 1] = bodies
        self.commands.write(state)
        self.compute_pass = None  # the subclass's

    def set(self, on) -> None:
        """Host-driven commands: `on` (envs bools) for the next execute()."""
        state = self.commands.read()
        state[:, 0] = np.asarray(on, dtype=bool).reshape(self.envs)
        self.commands.write(state)

    def execute(self) -> None:
        self.engine.execute_compute_pass(self.compute_pass)

    def count(self) -> np.ndarray:
        return self.commands.read()[:, 3].copy()


class TipTool(EnvTool):
    """A tool acting around a tip (Suction, Cautery): each env's tip is a point in one rigid body
    (`body_entities`, one per env in env order) or in the world (None), with a radius; `tips`,
    float32 (envs, 4) on the GPU: xyz the point in the body's frame, w the radius.
    `tip_bindings` binds the body poses a pass reads (the tips stand in without rigid bodies)."""

    def __init__(self, engine, name: str, body_entities, tip, radius: float, what: str):
        envs = engine.buffer("particles.env_ranges").shape[0]
        if not (np.isfinite(radius) and radius > 0):
            raise ValueError(f"{what}: radius must be positive, got {radius}")
        bodies = np.full(envs, -1, dtype=np.int32)
        if body_entities is not None:
            bodies[:] = body_rows(engine, body_entities, what)
        tips = np.broadcast_to(np.asarray(tip, dtype=np.float32), (envs, 3))
        if not np.isfinite(tips).all():
            raise ValueError(f"{what}: tip must be finite, got {tip}")
        super().__init__(engine, name, bodies)
        self.tips = engine.create_shared_buffer(f"{name}_tips", (envs, 4), "float32")
        self.tips.write(np.concatenate([tips, np.full((envs, 1), radius, np.float32)], axis=1))
        rigid = "rigid.positions" in engine.internal_keys
        self.tip_bindings = {"body_positions": "rigid.positions" if rigid else self.tips,
                             "body_rotations": "rigid.rotations" if rigid else self.tips}


def per_env(values, envs: int, what: str) -> np.ndarray:
    """`values` (one for all envs, or one per env) as float32 (envs,), each finite and >= 0;
    raises naming `what` and the first bad env."""
    v = np.broadcast_to(np.asarray(values, dtype=np.float64), (envs,))
    bad = ~(np.isfinite(v) & (v >= 0))
    if bad.any():
        env = int(np.nonzero(bad)[0][0])
        raise ValueError(f"{what} of env {env} must be finite and >= 0, got {v[env]:g}")
    return v.astype(np.float32)


def body_rows(engine, body_entities, what: str):
    """The rigid-body row of each env's body (entities or ids, one per env, in env order), checked:
    each must be a rigid body of its own env."""
    envs = engine.buffer("particles.env_ranges").shape[0]
    ids = [int(getattr(e, "id", e)) for e in body_entities]
    if len(ids) != envs:
        raise ValueError(f"{what}: {len(ids)} bodies for {envs} envs (one per env)")
    body_entity = engine.buffer("rigid.body_entity").read()
    body_env = engine.buffer("rigid.body_env").read()
    rows = []
    for env, entity in enumerate(ids):
        found = np.nonzero(body_entity == entity)[0]
        if len(found) != 1 or body_env[found[0]] != env:
            raise ValueError(f"{what}: entity {entity} is not a rigid body of env {env}")
        rows.append(int(found[0]))
    return rows
