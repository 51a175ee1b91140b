"""Ready-made custom compute passes (HLSL sources for Engine.create_compute_pass) and the tools
built on them: `grasp.Grasp` (jaws that hold soft bodies and threads), `suction.Suction` (a tip
that removes fluid)."""
from pathlib import Path


def source(name: str) -> str:
    """The HLSL of pass `name` ("grasp", "suction")."""
    path = Path(__file__).with_name(f"{name}.hlsl")
    if not path.exists():
        known = sorted(p.stem for p in Path(__file__).parent.glob("*.hlsl"))
        raise ValueError(f"no built-in pass '{name}'; known: {', '.join(known)}")
    return path.read_text()


def body_rows(engine, body_entities, what: str):
    """The rigid-body row of each env's body (entities or ids, one per env, in env order), checked:
    each must be a rigid body of its own env."""
    import numpy as np

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
