"""`cressim render scene.yaml`: images of a scene file's cameras for a person to look at.

For every camera of env 0 (or of every env): <env>_<camera>_rgb.png, _depth.png (colour-mapped,
near red, far blue), _segmentation.png (one colour per id, background black), _depth.npy (metric
depth in metres, float32; 0 where nothing was hit) and _depth.exr (the same depth as an OpenEXR
channel Z, float32 metres, +inf where nothing was hit)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

import cressim
from cressim import io
from cressim.scene_file import load_scene


def render(scene: str | Path, out_dir: str | Path = "out/render", *, all_envs: bool = False, steps: int = 0,
           device: str | None = None) -> list[Path]:
    """Loads `scene`, runs `steps` physics steps, renders once and writes the images; returns
    the paths written."""
    world = load_scene(scene)
    engine = cressim.Engine(world, device=device)
    engine.prepare()
    engine.upload_world()
    for _ in range(steps):
        engine.step_physics()
        engine.end_frame()
    engine.step_visual_sensors()
    engine.end_frame()
    cams = engine.cameras
    if len(cams["entity"]) == 0:
        raise ValueError(f"{scene}: the scene has no camera (an entity with a 'camera' field)")
    out, written, images = Path(out_dir), [], {}
    for entity, env, group, layer in zip(cams["entity"], cams["env"], cams["group"], cams["layer"]):
        if env != 0 and not all_envs:
            continue
        if group not in images:  # the products the camera writes
            keys = set(engine.internal_keys)
            images[group] = {k: engine.buffer(f"camera{group}.{k}").read() for k in ("rgb", "depth", "segmentation")
                             if f"camera{group}.{k}" in keys}
        img = {k: a[layer] for k, a in images[group].items()}
        name = world.entity(int(entity)).name or f"entity{entity}"
        stem = out / f"env{env}_{name}"
        if "rgb" in img:
            written.append(io.save_png(f"{stem}_rgb.png", img["rgb"][..., :3]))
        if "depth" in img:
            written.append(io.save_png(f"{stem}_depth.png", io.colour_depth(img["depth"])))
            np.save(f"{stem}_depth.npy", img["depth"])
            written.append(Path(f"{stem}_depth.npy"))
            written.append(io.save_exr(f"{stem}_depth.exr", depth=img["depth"]))
        if "segmentation" in img:
            written.append(io.save_png(f"{stem}_segmentation.png", io.colour_segmentation(img["segmentation"])))
    return written
