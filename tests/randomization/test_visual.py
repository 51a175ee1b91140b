"""Visual randomization: an env renders exactly what a scene authored with its drawn values renders
(a renderable's colour and texture, a light's intensity and colour, the ambient light, a
camera's pose), other envs are untouched, and a known point projects where the pinhole model
puts it from the drawn camera pose."""
import math

import numpy as np
import pytest

import cressim
from cressim.io import checker_texture
from cressim.randomization import RandomizationError, Randomizer

from .frames import randomized_frame

W = H = 64
FOV = 50.0
F = 0.5 * H / math.tan(math.radians(FOV / 2))
DOWN = (1.0, 0.0, 0.0, 0.0)  # the camera's +z (its view) turned to the world's -z
MARK = (0.15, -0.1, 0.0)     # a small ball on the slab, drawn with segmentation id 7


def quat_mul(a, b):
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return np.array([aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz])


def rotate(q, v):
    return quat_mul(quat_mul(q, (*v, 0.0)), (-q[0], -q[1], -q[2], q[3]))[:3]


def rotation_vector(v):
    """The quaternion (xyzw) of the rotation vector v (rad)."""
    angle = float(np.linalg.norm(v))
    if angle == 0:
        return np.array([0, 0, 0, 1.0])
    return np.array([*(np.sin(angle / 2) * np.asarray(v) / angle), np.cos(angle / 2)])


def build(make_engine, envs, *, slab_color=(0.6, 0.6, 0.6, 1.0), light=1.0, light_color=(1.0, 1.0, 1.0),
          camera=((0, 0, 1.0), DOWN), texture=-1, ambient=0.2):
    """Per env a grey slab (top at z = 0) with a marker ball, a light and an RGB + depth +
    segmentation camera; env 1's slab, light and camera have other names (no term reaches them).
    `slab_color`, `light`, `camera` (position, rotation): env 0's as authored, or per env lists."""
    world = cressim.World(cressim.SceneLayout(envs))
    slab, ball = world.add_mesh(cressim.Mesh.box((3.0, 3.0, 0.05))), world.add_mesh(cressim.Mesh.sphere(0.03, 16, 32))
    for colors in (((230, 40, 40), (40, 40, 230)), ((40, 200, 40), (240, 240, 240))):  # textures 0 and 1
        world.add_texture(checker_texture(64, 4, colors))
    per_env = lambda v, env: v[env] if isinstance(v, list) else v  # noqa: E731
    for env in range(envs):
        tag = "" if env != 1 else "other_"
        ground = world.create_entity(env=env, name=tag + "slab")
        ground.add(cressim.Transform(position=(0, 0, -0.05)))
        ground.add(cressim.Renderable(slab, color=tuple(per_env(slab_color, env)), texture=int(per_env(texture, env))))
        mark = world.create_entity(env=env, name="mark")
        mark.add(cressim.Transform(position=MARK))
        mark.add(cressim.Renderable(ball, color=(0.9, 0.1, 0.1, 1), segmentation_id=7))
        sun = world.create_entity(env=env, name=tag + "sun")
        sun.add(cressim.Transform(rotation=(0.985, 0.0, 0.0, 0.174)))  # travelling down, 20 deg off vertical
        sun.add(cressim.Light(intensity=per_env(light, env), color=tuple(per_env(light_color, env)),
                              ambient=per_env(ambient, env)))
        position, rotation = per_env(camera, env) if isinstance(camera, list) else camera
        cam = world.create_entity(env=env, name=tag + "camera")
        cam.add(cressim.Transform(position=tuple(position), rotation=tuple(rotation)))
        cam.add(cressim.Camera(width=W, height=H, fov_y=FOV))
    engine = make_engine(world)
    engine.prepare()
    engine.upload_world()
    return engine


def images(engine):
    """Each env's RGB and segmentation, in env order."""
    layer = np.argsort(np.asarray(engine.cameras["env"]))
    order = np.asarray(engine.cameras["layer"])[layer]
    return engine.buffer("camera0.rgb").read()[order], engine.buffer("camera0.segmentation").read()[order]


def render(engine):
    engine.step_visual_sensors()
    engine.end_frame()
    return images(engine)


def randomized(engine, terms, seed=0):
    r = Randomizer(engine, terms, seed=seed)
    randomized_frame(engine, r, reset_all=True, physics=False, sensors=["step_visual_sensors"])
    return r, images(engine)


def test_color_renders_as_the_drawn_colour_authored(make_engine):
    engine = build(make_engine, 3)
    plain, _ = render(engine)
    r, (rgb, _) = randomized(engine, [dict(param="color", entity="slab", range=[0.1, 0.9], operation="abs")], seed=2)
    color = r.read("color/slab")
    assert np.ptp(color[[0, 2]], axis=0).max() > 0.05
    reference, _ = render(build(make_engine, 3, slab_color=[(*c, 1.0) for c in color]))
    for env in (0, 2):
        assert np.abs(rgb[env].astype(int) - reference[env].astype(int)).max() <= 1
        assert np.abs(rgb[env].astype(int) - plain[env].astype(int)).max() > 2
    np.testing.assert_array_equal(rgb[1], plain[1])  # env 1's slab has another name


def test_light_intensity_renders_as_the_drawn_intensity_authored(make_engine):
    engine = build(make_engine, 3)
    plain, _ = render(engine)
    r, (rgb, _) = randomized(engine, [dict(param="light_intensity", entity="sun", distribution="log_uniform",
                                           range=[0.3, 3.0], operation="scale")], seed=4)
    scale = r.read("light_intensity/sun")[:, 0]
    reference, _ = render(build(make_engine, 3, light=[float(s) for s in scale]))
    for env in (0, 2):
        assert np.abs(rgb[env].astype(int) - reference[env].astype(int)).max() <= 1
        assert np.abs(rgb[env].astype(int) - plain[env].astype(int)).max() > 2
    np.testing.assert_array_equal(rgb[1], plain[1])


def test_light_color_renders_as_the_drawn_colour_authored(make_engine):
    engine = build(make_engine, 3)
    plain, _ = render(engine)
    r, (rgb, _) = randomized(engine, [dict(param="light_color", entity="sun", range=[0.3, 1.0], operation="abs")],
                             seed=5)
    color = r.read("light_color/sun")
    reference, _ = render(build(make_engine, 3, light_color=[tuple(map(float, c)) for c in color]))
    for env in (0, 2):
        assert np.abs(rgb[env].astype(int) - reference[env].astype(int)).max() <= 1
        assert np.abs(rgb[env].astype(int) - plain[env].astype(int)).max() > 2
    np.testing.assert_array_equal(rgb[1], plain[1])


def test_texture_renders_as_the_drawn_texture_authored(make_engine):
    engine = build(make_engine, 4)
    plain, _ = render(engine)
    r, (rgb, _) = randomized(engine, [dict(param="texture", entity="slab", distribution="choice", choices=[0, 1],
                                           operation="abs")], seed=1)
    drawn = r.read("texture/slab")[:, 0].astype(int)
    assert set(drawn) <= {0, 1}
    reference, _ = render(build(make_engine, 4, texture=[int(t) for t in drawn]))
    for env in (0, 2, 3):
        assert np.abs(rgb[env].astype(int) - reference[env].astype(int)).max() <= 1
        assert np.abs(rgb[env].astype(int) - plain[env].astype(int)).max() > 20  # checkered now
    np.testing.assert_array_equal(rgb[1], plain[1])
    with pytest.raises(RandomizationError, match=r"the world has 2 texture\(s\) \(indices 0 to 1, -1 none\)"):
        Randomizer(engine, [dict(param="texture", entity="slab", distribution="choice", choices=[0, 2])])


def test_ambient_renders_as_the_drawn_ambient_authored(make_engine):
    engine = build(make_engine, 3)
    plain, _ = render(engine)
    r, (rgb, _) = randomized(engine, [dict(param="ambient", entity="sun", range=[0.2, 3.0], operation="scale")], seed=3)
    scale = r.read("ambient/sun")[:, 0]
    reference, _ = render(build(make_engine, 3, ambient=[float(0.2 * s) for s in scale]))
    for env in (0, 2):
        assert np.abs(rgb[env].astype(int) - reference[env].astype(int)).max() <= 1
        assert np.abs(rgb[env].astype(int) - plain[env].astype(int)).max() > 2
    np.testing.assert_array_equal(rgb[1], plain[1])


def test_camera_pose_moves_the_projection_of_a_known_point(make_engine):
    engine = build(make_engine, 3)
    plain, _ = render(engine)
    r, (rgb, seg) = randomized(engine, [
        dict(param="camera_position", entity="camera", range=[[-0.1, 0.1], [-0.1, 0.1], [-0.2, 0.2]], operation="add"),
        dict(param="camera_rotation", entity="camera", distribution="gaussian", mean=0.0, std=0.05,
             clip=[-0.1, 0.1])], seed=6)
    offset, turn = r.read("camera_position/camera"), r.read("camera_rotation/camera")
    poses = [(np.array([0, 0, 1.0]) + offset[env], quat_mul(DOWN, rotation_vector(turn[env]))) for env in range(3)]
    for env in (0, 2):
        p, q = poses[env]
        top = np.array(MARK) + (0, 0, 0.03)  # the ball's top, then in the camera frame
        x = rotate(np.array([-q[0], -q[1], -q[2], q[3]]), top - p)
        v, u = np.nonzero(seg[env] == 7)
        expected = (F * x[0] / x[2] + W / 2, F * x[1] / x[2] + H / 2)
        assert abs(u.mean() + 0.5 - expected[0]) < 0.6 and abs(v.mean() + 0.5 - expected[1]) < 0.6, (env, expected)
    # the same images as cameras authored at the drawn poses
    reference, _ = render(build(make_engine, 3, camera=[(tuple(p), tuple(q)) for p, q in poses]))
    for env in (0, 2):
        assert np.abs(rgb[env].astype(int) - reference[env].astype(int)).max() <= 1
    np.testing.assert_array_equal(rgb[1], plain[1])
