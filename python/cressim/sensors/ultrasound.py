"""Ultrasound outputs on the host: one PNG per probe layer."""
from __future__ import annotations

from pathlib import Path

from cressim.io import save_png


def save_ultrasound_png(engine, out_dir, prefix: str = "ultrasound") -> list[Path]:
    """Writes each probe's B-mode image (ultrasound<group>.image_u8) as
    `<prefix>_env<env>_layer<k>.png` for group 0 and `<prefix><group>_env<env>_layer<k>.png` for
    the others, 8-bit grey."""
    probes = engine.ultrasound_probes
    images = {}
    paths = []
    for env, group, layer in zip(probes["env"], probes["group"], probes["layer"]):
        if group not in images:
            images[group] = engine.buffer(f"ultrasound{group}.image_u8").read()
        name = f"{prefix}{group if group else ''}_env{env}_layer{layer}.png"
        paths.append(save_png(Path(out_dir) / name, images[group][layer]))
    return paths
