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
