"""Frustum culling and the indirect draw list: an object outside the view leaves the image as
it was without it and is counted as culled (render.visible_counts: per camera, visible and
culled instances); a scene with objects in, out of and across the view's edges renders the
same with CRESSIM_CULLING=0 (every instance drawn), on both rasterizers."""
import numpy as np
import pytest

import cressim

pytestmark = pytest.mark.usefixtures("raster")

S = 48
DOWN = (1.0, 0.0, 0.0, 0.0)  # looking down -z from z = 2: the view is 1.04 m a side at z = 0.2


def render(make_engine, spheres, envs=1):
    world = cressim.World(cressim.SceneLayout(envs))
    ball, plane = world.add_mesh(cressim.Mesh.sphere(0.2, 8, 16)), world.add_mesh(cressim.Mesh.plane(1.0))
    for env in range(envs):
        floor = world.create_entity(env=env, name="floor")
        floor.add(cressim.Transform())
        floor.add(cressim.Renderable(plane, color=(0.6, 0.6, 0.6, 1)))
        for k, p in enumerate(spheres):
            e = world.create_entity(env=env, name=f"ball{k}")
            e.add(cressim.Transform(position=(p[0] + 0.1 * env, p[1], p[2])))
            e.add(cressim.Renderable(ball, color=(0.9, 0.3 * k % 1, 0.2, 1)))
        cam = world.create_entity(env=env, name="camera")
        cam.add(cressim.Transform(position=(0, 0, 2), rotation=DOWN))
        cam.add(cressim.Camera(width=S, height=S, fov_y=60))
    engine = make_engine(world)
    engine.prepare()
    engine.upload_world()
    engine.step_visual_sensors()
    engine.end_frame()
    images = {k: engine.buffer(f"camera0.{k}").read() for k in ("rgb", "depth", "segmentation")}
    return images, engine.buffer("render.visible_counts").read()


IN_VIEW = [(0.3, 0.0, 0.2), (-0.4, 0.3, 0.2)]
OUT_OF_VIEW = [(5.0, 0.0, 0.2), (0.0, 0.0, 3.0)]  # far aside; behind the camera
ACROSS_EDGE = [(1.15, 0.0, 0.2)]  # centre outside the view, part of it inside


def test_object_out_of_view_is_culled_and_changes_nothing(make_engine):
    alone, counts_alone = render(make_engine, IN_VIEW)
    with_far, counts = render(make_engine, IN_VIEW + OUT_OF_VIEW[:1])
    for k in alone:
        assert np.array_equal(alone[k], with_far[k]), k
    assert counts_alone.tolist() == [[3, 0]]  # floor and two balls
    assert counts.tolist() == [[3, 1]]


def test_culling_on_and_off_give_the_same_images(make_engine, monkeypatch):
    scene = IN_VIEW + OUT_OF_VIEW + ACROSS_EDGE
    on, counts_on = render(make_engine, scene, envs=3)
    monkeypatch.setenv("CRESSIM_CULLING", "0")
    off, counts_off = render(make_engine, scene, envs=3)
    for k in on:
        assert np.array_equal(on[k], off[k]), k
    # the ball across the edge shows (env 0: x 1.15 - 0.2 = 0.95 < 1.04) and is drawn
    assert (on["segmentation"][0] == on["segmentation"][0].max()).any()
    # floor, 2 in view, 1 across; 2 out. Env 2 moves the balls 0.2 m along x: the one across
    # the edge (x 1.35 - 0.2 > 1.04) is then out as well
    assert counts_on.tolist() == [[4, 2], [4, 2], [3, 3]]
    assert counts_off.tolist() == [[6, 0]] * 3


def test_bad_culling_setting_is_named(make_engine, monkeypatch):
    monkeypatch.setenv("CRESSIM_CULLING", "yes")
    with pytest.raises(Exception, match="CRESSIM_CULLING='yes'"):
        render(make_engine, IN_VIEW)
