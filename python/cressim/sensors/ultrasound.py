"""Ultrasound outputs on the host: one PNG per probe layer."""
from __future__ import annotations

from pathlib import Path

from .png import write_png


def save_ultrasound_png(engine, out_dir, prefix: str = "ultrasound") -> list[Path]:
    """Writes each probe's B-mode image (ultrasound0.image) as `<prefix>_env<env>_layer<k>.png`."""
    images = engine.buffer("ultrasound0.image").read()
    probes = engine.ultrasound_probes
    return [write_png(Path(out_dir) / f"{prefix}_env{env}_layer{layer}.png", images[layer])
            for env, layer in zip(probes["env"], probes["layer"])]
