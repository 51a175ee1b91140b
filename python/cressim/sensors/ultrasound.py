"""Ultrasound outputs on the host: one PNG per probe layer."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from cressim.io import save_png


def save_ultrasound_png(engine, out_dir, prefix: str = "ultrasound") -> list[Path]:
    """Writes each probe's B-mode image (ultrasound0.image, brightness in [0, 1]) as
    `<prefix>_env<env>_layer<k>.png`, 8-bit grey."""
    images = (np.clip(engine.buffer("ultrasound0.image").read(), 0, 1) * 255 + 0.5).astype(np.uint8)
    probes = engine.ultrasound_probes
    return [save_png(Path(out_dir) / f"{prefix}_env{env}_layer{layer}.png", images[layer])
            for env, layer in zip(probes["env"], probes["layer"])]
