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
