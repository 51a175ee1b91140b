"""The batched rasterizer checked analytically: projected areas, metric depth, intrinsics,
segmentation ids, and env isolation of the layered targets."""
import math

import numpy as np
import pytest
import torch

import cressim

pytestmark = pytest.mark.usefixtures("raster")  # each test on both rasterizers

W = H = 128
FOV = 40.0
F = 0.5 * H / math.tan(math.radians(FOV / 2))  # focal length in pixels


def scene(make_engine, envs, place, **camera):
    """place(world, env, sphere_mesh) authors each env; one camera per env at the origin looking +z."""
    world = cressim.World(cressim.SceneLayout(envs, max_cameras_per_env=1))
    sphere = world.add_mesh(cressim.Mesh.sphere(1.0, 64, 128))  # unit sphere, sized by Transform.scale
    for env in range(envs):
        place(world, env, sphere)
        cam = world.create_entity(env=env, name="camera")
        cam.add(cressim.Transform())
        cam.add(cressim.Camera(width=W, height=H, fov_y=FOV, **camera))
    engine = make_engine(world)
    engine.prepare()
    engine.upload_world()
    engine.step_visual_sensors()
    engine.end_frame()
    return engine, world


def ball(world, env, mesh, position, radius, **renderable):
    b = world.create_entity(env=env, name="ball")
    b.add(cressim.Transform(position=position, scale=(radius, radius, radius)))
    b.add(cressim.Renderable(mesh, **renderable))
    return b


def images(engine):
    return (engine.buffer("camera0.rgb").read(), engine.buffer("camera0.depth").read(),
            engine.buffer("camera0.segmentation").read())


def test_sphere_area_and_centre_depth(make_engine):
    r, d = 0.1, 1.0
    engine, _ = scene(make_engine, 1, lambda w, env, m: ball(w, env, m, (0, 0, d), r))
    rgb, depth, seg = images(engine)
    disc = F * r / math.sqrt(d * d - r * r)  # radius of the projected disc (tangent cone)
    assert abs((seg[0] > 0).sum() / (math.pi * disc * disc) - 1) < 0.02
    centre = depth[0, H // 2 - 1: H // 2 + 1, W // 2 - 1: W // 2 + 1]
    assert np.all(np.abs(centre - (d - r)) < 1e-3)  # metres along the optical axis
    assert depth[0, 0, 0] == 0 and seg[0, 0, 0] == 0  # background
    assert rgb[0, H // 2, W // 2, :3].max() > 40  # lit


def test_shared_edges_leave_no_holes(make_engine):
    # a square facing the camera: its diagonal, the edge its two triangles share, runs through
    # pixel centres, which one triangle or the other must cover (the compute rasterizer once
    # left a dotted line there on NVIDIA)
    def place(world, env, sphere):
        e = world.create_entity(env=env, name="square")
        e.add(cressim.Transform(position=(0, 0, 1)))
        e.add(cressim.Renderable(world.add_mesh(cressim.Mesh.plane(0.2))))

    seg = images(scene(make_engine, 1, place)[0])[2][0]
    half = F * 0.2  # 35 pixels
    inside = seg[math.ceil(H / 2 - half) + 1:math.floor(H / 2 + half) - 1, math.ceil(W / 2 - half) + 1:math.floor(W / 2 + half) - 1]
    assert inside.size > 4000 and np.all(inside > 0), np.argwhere(inside == 0)[:8]


def test_intrinsics_round_trip_a_projected_point(make_engine):
    p = np.array([0.12, -0.07, 1.5])
    engine, _ = scene(make_engine, 1, lambda w, env, m: ball(w, env, m, tuple(p), 0.01), fx=100.0, fy=110.0, cx=60.0,
                      cy=70.0)
    seg = images(engine)[2][0]
    v, u = np.nonzero(seg)
    expected = (100.0 * p[0] / p[2] + 60.0, 110.0 * p[1] / p[2] + 70.0)
    assert abs(u.mean() + 0.5 - expected[0]) < 0.5 and abs(v.mean() + 0.5 - expected[1]) < 0.5  # pixel centres


def test_segmentation_ids_and_env_isolation(make_engine):
    def place(world, env, mesh):
        # env 0: one ball left with its own id; env 1: one ball right with the default id
        if env == 0:
            ball(world, env, mesh, (-0.2, 0, 1.0), 0.1, segmentation_id=42, color=(1, 0, 0, 1))
        else:
            ball(world, env, mesh, (0.2, 0, 1.0), 0.1, color=(0, 0, 1, 1))

    engine, world = scene(make_engine, 2, place)
    rgb, depth, seg = images(engine)
    cams = engine.cameras
    assert list(cams["env"]) == [0, 1] and list(cams["layer"]) == [0, 1]
    right_ball = [e for e in range(world.entity_count) if world.entity(e).env == 1 and world.entity(e).name == "ball"][0]
    assert set(np.unique(seg[0])) == {0, 42} and set(np.unique(seg[1])) == {0, right_ball + 1}
    assert seg[0][:, W // 2:].max() == 0 and seg[1][:, : W // 2].max() == 0  # each layer shows its env only
    assert rgb[0][seg[0] > 0][:, 0].mean() > rgb[0][seg[0] > 0][:, 2].mean()  # red ball in env 0
    assert rgb[1][seg[1] > 0][:, 2].mean() > rgb[1][seg[1] > 0][:, 0].mean()  # blue in env 1


def test_images_follow_physics_and_are_torch_views(make_engine):
    world = cressim.World(cressim.SceneLayout(1))
    mesh = world.add_mesh(cressim.Mesh.sphere(0.05))
    b = world.create_entity(env=0, name="falling")
    b.add(cressim.Transform(position=(0, 0, 1.0)))
    b.add(cressim.RigidBody(mass=1))
    b.add(cressim.Collider(cressim.Shape.sphere(0.05)))
    b.add(cressim.Renderable(mesh))
    cam = world.create_entity(env=0, name="camera")
    cam.add(cressim.Transform(position=(0, -1.0, 0.5), rotation=(-math.sqrt(0.5), 0, 0, math.sqrt(0.5))))  # looking +y
    cam.add(cressim.Camera(width=64, height=64, fov_y=60))
    engine = make_engine(world)
    engine.prepare()
    engine.upload_world()
    seg = engine.buffer("camera0.segmentation")
    rows = []
    for _ in range(20):
        engine.step_physics()
        engine.step_visual_sensors()
        engine.end_frame()
        rows.append(np.nonzero(seg.read()[0])[0].mean())
    assert rows[-1] > rows[0] + 3  # the ball falls: it moves down the image (y down)
    if seg.host_visible:
        t = torch.from_dlpack(engine.buffer("camera0.depth"))
        assert t.shape == (1, 64, 64) and t.dtype == torch.float32


def test_capacity_errors_name_the_env(make_engine):
    world = cressim.World(cressim.SceneLayout(2, max_cameras_per_env=1))
    for k in range(2):
        c = world.create_entity(env=1, name=f"cam{k}")
        c.add(cressim.Transform())
        c.add(cressim.Camera())
    with pytest.raises(ValueError, match="'cam1' in env 1: env 1 has more cameras than SceneLayout.max_cameras_per_env = 1"):
        make_engine(world).prepare()
    world2 = cressim.World(cressim.SceneLayout(1))
    world2.create_entity(env=0, name="thing").add(cressim.Renderable(3))
    with pytest.raises(ValueError, match="'thing' in env 0: Renderable.mesh 3 is not a mesh"):
        make_engine(world2).prepare()


def test_camera_products_select_the_buffers(make_engine):
    # an RGB-only and a depth-only camera beside a full one see the same ball: same pixels, fewer buffers
    world = cressim.World(cressim.SceneLayout(1, max_cameras_per_env=3))
    sphere = world.add_mesh(cressim.Mesh.sphere(1.0, 32, 64))
    ball(world, 0, sphere, (0, 0, 1.0), 0.1)
    for name, products in (("full", ["rgb", "depth", "segmentation"]), ("rgb", ["rgb"]), ("depth", ["depth"])):
        cam = world.create_entity(env=0, name=name)
        cam.add(cressim.Transform())
        cam.add(cressim.Camera(width=32, height=32, fov_y=FOV, products=products))
    engine = make_engine(world)
    engine.prepare()
    engine.upload_world()
    engine.step_visual_sensors()
    engine.end_frame()
    groups = dict(zip([world.entity(int(e)).name for e in engine.cameras["entity"]], engine.cameras["group"]))
    keys = set(engine.internal_keys)
    has = {name: {k for k in ("rgb", "depth", "segmentation") if f"camera{g}.{k}" in keys} for name, g in groups.items()}
    assert has == {"full": {"rgb", "depth", "segmentation"}, "rgb": {"rgb"}, "depth": {"depth"}}
    full, rgb, depth = (f"camera{groups[n]}." for n in ("full", "rgb", "depth"))
    assert np.array_equal(engine.buffer(full + "rgb").read(), engine.buffer(rgb + "rgb").read())
    assert np.array_equal(engine.buffer(full + "depth").read(), engine.buffer(depth + "depth").read())
    with pytest.raises(ValueError, match="Camera product 'normals' is not one of: rgb, depth, segmentation"):
        cressim.Camera(products=["normals"])


def test_tile_size_leaves_the_image_unchanged(make_engine):
    """The compute rasterizer shrinks its 64x32 tiles (down to 16x16) for few small images: one
    128x128 camera is drawn in 16x16 tiles, 64 of them in 64x32 tiles; env 0 is drawn alike."""
    def place(world, env, mesh):
        ball(world, env, mesh, (0.05, -0.02, 0.8), 0.12)
        ball(world, env, mesh, (-0.1, 0.05, 1.2), 0.3, color=(0.8, 0.3, 0.2, 1))

    one, _ = scene(make_engine, 1, place)
    many, _ = scene(make_engine, 64, place)
    for a, b in zip(images(one), images(many)):
        np.testing.assert_array_equal(a[0], b[0])
    assert (images(one)[2][0] > 0).mean() > 0.2  # both balls cover a good part of the image
