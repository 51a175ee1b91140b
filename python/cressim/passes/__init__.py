"""Ready-made custom compute passes (HLSL sources for Engine.create_compute_pass)."""
from pathlib import Path

ALL_ENVS = 0xFFFFFFFF


def source(name: str) -> str:
    """The HLSL of pass `name` (e.g. "suction": flag fluid near a tip for removal)."""
    path = Path(__file__).with_name(f"{name}.hlsl")
    if not path.exists():
        known = sorted(p.stem for p in Path(__file__).parent.glob("*.hlsl"))
        raise ValueError(f"no built-in pass '{name}'; known: {', '.join(known)}")
    return path.read_text()
