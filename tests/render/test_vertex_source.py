"""The hook for particle surfaces: a mesh whose vertex positions are copied every frame from an
engine buffer by key (here transform.positions: three entities are a triangle's corners)."""
import math

import numpy as np
import pytest

import cressim

pytestmark = pytest.mark.usefixtures("raster")  # each test on both rasterizers

S = 64
F = 0.5 * S / math.tan(math.radians(25))  # fov 50


def triangle_scene(make_engine, key="transform.positions"):
    world = cressim.World(cressim.SceneLayout(1))
    corners = [(-0.2, -0.2, 1.0), (0.2, -0.2, 1.0), (0.0, 0.2, 1.0)]
    ents = []
    for i, p in enumerate(corners):  # the env's first three rows
        ents.append(world.create_entity(env=0, name=f"corner{i}"))
        ents[-1].add(cressim.Transform(position=p))
    mesh = world.add_mesh(cressim.Mesh(np.array(corners, np.float32), np.array([[0, 1, 2]], np.uint32),
                                       np.zeros((3, 3), np.float32), positions_key=key))
    tri = world.create_entity(env=0, name="surface")
    tri.add(cressim.Transform())
    tri.add(cressim.Renderable(mesh, segmentation_id=7))
    cam = world.create_entity(env=0, name="camera")
    cam.add(cressim.Transform())
    cam.add(cressim.Camera(width=S, height=S, fov_y=50))
    engine = make_engine(world)
    engine.prepare()
    engine.upload_world()
    return engine, ents


def test_mesh_positions_follow_an_engine_buffer(make_engine):
    engine, corners = triangle_scene(make_engine)
    engine.step_visual_sensors()
    engine.end_frame()
    seg = engine.buffer("camera0.segmentation").read()[0]
    assert abs((seg == 7).sum() / (0.5 * 0.4 * 0.4 * F * F) - 1) < 0.05  # the triangle's projected area
    assert engine.buffer("camera0.rgb").read()[0][seg == 7][:, :3].max() > 0  # shaded (flat normals)
    corners[2].transform = cressim.Transform(position=(0.0, 0.4, 1.0))  # the apex moves on the GPU buffer
    engine.step_visual_sensors()
    engine.end_frame()
    seg = engine.buffer("camera0.segmentation").read()[0]
    assert abs((seg == 7).sum() / (0.5 * 0.4 * 0.6 * F * F) - 1) < 0.05


def test_unknown_key_is_named(make_engine):
    with pytest.raises(ValueError, match="mesh 0: positions_key 'particle.nothing' is not an engine buffer"):
        triangle_scene(make_engine, key="particle.nothing")
