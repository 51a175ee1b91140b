"""Golden image of particles drawn from the physics buffers: a lit scene (checker-textured
ground, textured crate, sun with shadows) with a soft body and a fluid pool, as authored (no
physics step, so solver changes do not move it), 96x72, against a committed PNG; both
rasterizers. Tolerance as test_golden.py: mean absolute difference <= 1.5 levels and at most
1 % of pixels off by more than 24 levels. A failing test writes the image and the diff (x4) next
to each other and names the folder. CRESSIM_UPDATE_GOLDEN=1 rewrites the PNG (graphics path)."""
import os
from pathlib import Path

import numpy as np
import pytest

import cressim
from cressim import io
from cressim.scene_file import _quat_look_at

from .particle_render_scenes import lattice

GOLDEN = Path(__file__).with_name("golden") / "particle_scene.png"


def particle_scene(width=96, height=72):
    world = cressim.World(cressim.SceneLayout(1))
    floor = world.add_mesh(cressim.Mesh.plane(1.0))
    crate = world.add_mesh(cressim.Mesh.box((0.08, 0.08, 0.08)))
    checker = world.add_texture(io.checker_texture(64, 8))
    tiles = world.add_texture(io.checker_texture(32, 4, ((230, 150, 50), (80, 40, 10))))
    ground = world.create_entity(env=0, name="ground")
    ground.add(cressim.Transform())
    ground.add(cressim.Renderable(floor, texture=checker, roughness=0.8, segmentation_id=1))
    box = world.create_entity(env=0, name="crate")
    box.add(cressim.Transform(position=(0.22, 0.12, 0.08)))
    box.add(cressim.Renderable(crate, texture=tiles, color=(1, 1, 1, 1), roughness=0.6, segmentation_id=2))
    cube = world.create_entity(env=0, name="tissue")
    cube.add(cressim.Transform(position=(-0.12, 0.1, 0.1), rotation=(0, 0, 0.259, 0.966)))
    cube.add(cressim.SoftBody(cressim.TetMesh.box((0.08, 0.08, 0.08), (3, 3, 3)), radius=0.02))
    cube.add(cressim.Material(color=(0.8, 0.35, 0.3, 1), roughness=0.4, segmentation_id=3))
    pool = world.create_entity(env=0, name="blood")
    r = 0.015
    pool.add(cressim.Fluid(lattice((10, 6, 2), 2 * r, (-0.1, -0.22, r)), radius=r))
    pool.add(cressim.Material(color=(0.35, 0.01, 0.01, 1), roughness=0.1, segmentation_id=4))
    sun = world.create_entity(env=0, name="sun")
    sun.add(cressim.Transform(position=(0, 0, 1), rotation=_quat_look_at((0, 0, 1), (0.5, -0.3, 0))))
    sun.add(cressim.Light(intensity=2.2, shadows=True, shadow_extent=0.6, shadow_resolution=256))
    cam = world.create_entity(env=0, name="camera")
    eye = (0.0, -0.75, 0.5)
    cam.add(cressim.Transform(position=eye, rotation=_quat_look_at(eye, (0, 0.0, 0.05))))
    cam.add(cressim.Camera(width=width, height=height, fov_y=50))
    return world


@pytest.mark.parametrize("raster", ["graphics", "compute"])
def test_particle_scene_matches_golden(make_engine, raster, monkeypatch, tmp_path):
    monkeypatch.setenv("CRESSIM_RASTER", raster)
    engine = make_engine(particle_scene())
    engine.prepare()
    engine.upload_world()
    engine.step_visual_sensors()
    engine.end_frame()
    image = engine.buffer("camera0.rgb").read()[0, ..., :3].astype(int)
    seg = engine.buffer("camera0.segmentation").read()[0]
    for sid in (1, 2, 3, 4):  # every object is in view
        assert (seg == sid).sum() > 20, sid
    if os.environ.get("CRESSIM_UPDATE_GOLDEN") == "1" and raster == "graphics":
        io.save_png(GOLDEN, image.astype(np.uint8))
    golden = io.read_png(GOLDEN)[..., :3].astype(int)
    diff = np.abs(image - golden)
    mean, off = diff.mean(), (diff.max(-1) > 24).mean()
    if mean > 1.5 or off > 0.01:
        io.save_png(tmp_path / "image.png", image.astype(np.uint8))
        io.save_png(tmp_path / "diff.png", np.clip(diff * 4, 0, 255).astype(np.uint8))
        raise AssertionError(f"{raster}: differs from {GOLDEN}: mean {mean:.2f} levels, {100 * off:.2f} % of "
                             f"pixels > 24; image and diff (x4) in {tmp_path}")
