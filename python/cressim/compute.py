"""Custom compute passes from HLSL files."""
from __future__ import annotations

from pathlib import Path

from cressim._core import ComputePass, Engine


def load_compute_pass(engine: Engine, path: str | Path, **kwargs) -> ComputePass:
    """Compiles the HLSL file at `path` (relative #includes resolve beside it); keyword
    arguments are those of `Engine.create_compute_pass`, `name` defaulting to the path."""
    path = Path(path)
    kwargs.setdefault("name", str(path))
    return engine.create_compute_pass(path.read_text(), **kwargs)
