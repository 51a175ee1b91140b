"""Image-based lighting (EnvironmentLight.map), on both rasterizers, against closed forms: a
white Lambertian sphere under a uniform map of radiance L shows L (within 2 %); a map of sky
blue above and brown below lights the sphere's top blue and its bottom brown; a mirror sphere
shows a bright spot of the map at the pixel that a ray traced here predicts."""
import math

import numpy as np
import pytest

import cressim

pytestmark = pytest.mark.usefixtures("raster")

S = 64
FOV = 40.0
DOWN = (1.0, 0.0, 0.0, 0.0)  # at (0, 0, 3) looking down -z: image x = world x, image y = world -y


def render(make_engine, image, intensity=1.0, camera=((0, 0, 3), DOWN), **material):
    world = cressim.World(cressim.SceneLayout(1))
    tex = world.add_texture(cressim.Texture(np.ascontiguousarray(image, dtype=np.uint8)))
    sky = world.create_entity(env=0, name="environment")
    sky.add(cressim.EnvironmentLight(map=tex, intensity=intensity))
    dark = world.create_entity(env=0, name="no direct light")  # else a default light from above
    dark.add(cressim.Transform())
    dark.add(cressim.Light(intensity=0.0))
    ball = world.create_entity(env=0, name="ball")
    ball.add(cressim.Transform())
    ball.add(cressim.Renderable(world.add_mesh(cressim.Mesh.sphere(0.5, 48, 96)), **material))
    cam = world.create_entity(env=0, name="camera")
    cam.add(cressim.Transform(position=camera[0], rotation=camera[1]))
    cam.add(cressim.Camera(width=S, height=S, fov_y=FOV))
    engine = make_engine(world)
    engine.prepare()
    engine.upload_world()
    engine.step_visual_sensors()
    engine.end_frame()
    rgb = engine.buffer("camera0.rgb").read()[0][..., :3].astype(float)
    return (rgb / 255) ** 2.2, engine.buffer("camera0.depth").read()[0]


def test_uniform_map_lights_a_white_lambertian_sphere_to_its_radiance(make_engine):
    value, intensity = 200, 0.8
    L = (value / 255) ** 2.2 * intensity
    linear, depth = render(make_engine, np.full((8, 16, 4), value), intensity, color=(1, 1, 1, 1), roughness=1.0)
    hit = depth > 0
    assert hit.sum() > 500
    # diffuse (1 - s) L + specular s L = L for any normal; 8-bit output adds < 0.5 %
    assert np.abs(linear[hit] / L - 1).max() < 0.02


def test_sky_above_and_ground_below_colour_top_and_bottom(make_engine):
    img = np.zeros((16, 32, 4), np.uint8)
    img[:8] = (110, 160, 235, 255)  # sky blue, rows from +z
    img[8:] = (120, 75, 35, 255)    # brown
    from cressim.scene_file import _quat_look_at
    side = ((0, -3, 0), _quat_look_at((0, -3, 0), (0, 0, 0)))  # image up = world +z
    linear, depth = render(make_engine, img, camera=side, color=(1, 1, 1, 1), roughness=1.0)
    rows = np.nonzero(depth[:, S // 2] > 0)[0]
    top, bottom = linear[rows[0] + 1, S // 2], linear[rows[-1] - 1, S // 2]
    assert top[2] > 1.3 * top[0] and bottom[0] > 1.3 * bottom[2], (top, bottom)


def test_mirror_sphere_reflects_a_bright_spot_where_predicted(make_engine):
    h, w = 64, 128
    img = np.full((h, w, 4), 12, np.uint8)
    theta, phi = math.radians(50), math.radians(30)  # the spot's direction: 50 deg from +z, 30 deg from +x
    row, col = int(theta / math.pi * h), int((phi / (2 * math.pi) + 0.5) * w)
    img[row - 1:row + 2, col - 1:col + 2] = 255
    spot = np.array([math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta)])
    linear, depth = render(make_engine, img, color=(1, 1, 1, 1), metallic=1.0, roughness=0.0)
    # trace each pixel centre's ray to the sphere and reflect it; the pixel nearest the spot
    f = 0.5 * S / math.tan(math.radians(FOV / 2))
    v, u = np.mgrid[0:S, 0:S] + 0.5
    d = np.stack([(u - S / 2) / f, -(v - S / 2) / f, -np.ones_like(u)], -1)  # camera frame to world
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    eye = np.array([0, 0, 3.0])
    b = d @ eye
    disc = b * b - (eye @ eye - 0.25)
    t = -b - np.sqrt(np.maximum(disc, 0))
    n = eye + t[..., None] * d
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    r = d - 2 * (d * n).sum(-1, keepdims=True) * n
    angle = np.where(disc > 0, np.arccos(np.clip(r @ spot, -1, 1)), np.inf)
    predicted = np.array(np.unravel_index(np.argmin(angle), angle.shape))
    brightest = np.array(np.unravel_index(np.argmax(linear.sum(-1)), (S, S)))
    assert np.abs(brightest - predicted).max() <= 1, (brightest, predicted)
    assert linear[tuple(brightest)].min() > 0.5  # the spot (1.0), not the dark map (0.004)


def test_bad_map_is_named(make_engine):
    world = cressim.World(cressim.SceneLayout(1))
    world.create_entity(env=0, name="sky").add(cressim.EnvironmentLight(map=3))
    cam = world.create_entity(env=0, name="camera")
    cam.add(cressim.Transform())
    cam.add(cressim.Camera(width=8, height=8))
    engine = make_engine(world)
    with pytest.raises(Exception, match="sky.*EnvironmentLight.map 3 is not a texture"):
        engine.prepare()
