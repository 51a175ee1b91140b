"""Lights and materials checked against the shading model's closed forms: a white matte
surface facing a directional light, the inverse square of a point light, a spot's cone, a
directional light's shadow, a checker texture sampled through uvs, magnified and minified
(mip levels), and normal maps against planes tilted for real."""
import math

import numpy as np
import pytest

import cressim

pytestmark = pytest.mark.usefixtures("raster")  # each test on both rasterizers
from cressim.scene_file import _quat_look_at

S = 64
DOWN = (1.0, 0.0, 0.0, 0.0)  # a camera looking down -z (x right = world x, y down = world -y)


def srgb(linear):
    return 255 * min(max(linear, 0.0), 1.0) ** (1 / 2.2)


def render(make_engine, place, *, fov=60.0, lights=4):
    world = cressim.World(cressim.SceneLayout(1, max_lights_per_env=lights))
    world.create_entity(env=0, name="dark").add(cressim.EnvironmentLight(sky=(0, 0, 0), ground=(0, 0, 0)))
    place(world)
    cam = world.create_entity(env=0, name="camera")
    cam.add(cressim.Transform(position=(0, 0, 2), rotation=DOWN))
    cam.add(cressim.Camera(width=S, height=S, fov_y=fov))
    engine = make_engine(world)
    engine.prepare()
    engine.upload_world()
    engine.step_visual_sensors()
    engine.end_frame()
    return engine.buffer("camera0.rgb").read()[0].astype(float)


def floor(world, size=2.0, **material):
    mesh = world.add_mesh(cressim.Mesh.plane(size))
    e = world.create_entity(env=0, name="floor")
    e.add(cressim.Transform())
    e.add(cressim.Renderable(mesh, color=(1, 1, 1, 1), roughness=1.0, **material))


def light(world, position=(0, 0, 0), look_at=None, rotation=(0, 0, 0, 1), **kw):
    e = world.create_entity(env=0, name=kw.get("kind", "light"))
    if look_at is not None:
        rotation = _quat_look_at(position, look_at)
    e.add(cressim.Transform(position=position, rotation=rotation))
    e.add(cressim.Light(**kw))
    return e


def test_white_matte_surface_facing_a_directional_light(make_engine):
    # light straight down, camera straight down: n = l = v. Diffuse (1 - F0) + GGX specular at
    # roughness 1 (D = 1/pi, G = 1, F = F0 = 0.04: pi D G F / 4 = 0.01) = 0.97 of the light.
    def place(world):
        floor(world)
        light(world, rotation=DOWN, intensity=0.5)

    rgb = render(make_engine, place)
    assert abs(rgb[S // 2, S // 2, 0] - srgb(0.97 * 0.5)) <= 1.5  # within 1.5 of 255 levels


def test_point_light_falls_off_with_the_square_of_distance(make_engine):
    # a point light 1 m above the floor, straight under the camera: the pixel under it gets
    # 0.97 I; a point 0.5 m aside gets I cos(theta) / d^2 x (diffuse + specular at that angle)
    def place(world):
        floor(world)
        light(world, position=(0, 0, 1.0), kind="point", intensity=0.4)

    rgb = render(make_engine, place)
    assert abs(rgb[S // 2, S // 2, 0] - srgb(0.97 * 0.4)) <= 1.5
    f = 0.5 * S / math.tan(math.radians(30))
    u = round(S / 2 + f * 0.5 / 2 - 0.5)  # the pixel 0.5 m along x (camera 2 m up)
    d2, cos = 1.25, 1 / math.sqrt(1.25)
    dim = 0.4 * cos / d2 * 0.96  # diffuse share; the specular lobe at roughness 1 adds ~1 %
    assert abs(rgb[S // 2, u, 0] - srgb(dim)) <= 3


def test_spot_light_lights_its_cone_only(make_engine):
    def place(world):
        floor(world)
        light(world, position=(0, 0, 1.0), rotation=DOWN, kind="spot", intensity=1.0, inner_angle=10,
              outer_angle=15)

    rgb = render(make_engine, place)
    f = 0.5 * S / math.tan(math.radians(30))
    inside = round(S / 2 + f * math.tan(math.radians(5)) / 2)  # 5 deg from the axis, 1 m down
    outside = round(S / 2 + f * math.tan(math.radians(25)) / 2)
    assert rgb[S // 2, inside, 0] > 200 and rgb[S // 2, outside, 0] == 0


def test_directional_shadow_falls_where_the_light_is_blocked(make_engine):
    # sun travelling along (1, 0, -1): a box floating 0.5 m up shades the floor 0.5 m towards +x
    def place(world, shadows):
        floor(world)
        box = world.add_mesh(cressim.Mesh.box((0.15, 0.15, 0.15)))
        b = world.create_entity(env=0, name="box")
        b.add(cressim.Transform(position=(0, 0, 0.5)))
        b.add(cressim.Renderable(box))
        light(world, position=(0, 0, 1), look_at=(1, 0, 0), shadows=shadows, shadow_extent=1.5)

    f = 0.5 * S / math.tan(math.radians(30))
    shaded, mirrored = (round(S / 2 + f * x / 2 - 0.5) for x in (0.5, -0.5))
    lit = render(make_engine, lambda w: place(w, False))
    dark = render(make_engine, lambda w: place(w, True))
    assert abs(lit[S // 2, shaded, 0] - lit[S // 2, mirrored, 0]) <= 1
    assert dark[S // 2, shaded, 0] == 0  # no ambient: fully dark
    assert abs(dark[S // 2, mirrored, 0] - lit[S // 2, mirrored, 0]) <= 1


def test_checker_texture_through_uvs(make_engine):
    # a 1 m plane (uvs 0..1) with 8 x 8 squares, seen from 2 m: square centres alternate
    def place(world):
        tex = world.add_texture(cressim.Texture(np.kron((np.indices((8, 8)).sum(0) % 2) * 255,
                                                        np.ones((8, 8)))[..., None].repeat(3, 2).astype(np.uint8)))
        mesh = world.add_mesh(cressim.Mesh.plane(0.5))
        e = world.create_entity(env=0, name="floor")
        e.add(cressim.Transform())
        e.add(cressim.Renderable(mesh, color=(1, 1, 1, 1), roughness=1.0, texture=tex))
        light(world, rotation=DOWN, intensity=1.0)

    rgb = render(make_engine, place, fov=30)
    f = 0.5 * S / math.tan(math.radians(15))
    centres = [-0.4375 + 0.125 * k for k in range(8)]  # square centres along x, at y = 1/16
    px = [round(S / 2 + f * x / 2 - 0.5) for x in centres]
    row = round(S / 2 - f * 0.0625 / 2 - 0.5)  # world y up is image up
    values = rgb[row, px, 0]
    # white squares: 0.97 of the light; black ones keep the specular 0.01 (srgb 32)
    white, black = srgb(0.97), srgb(0.01)
    assert np.all(np.abs(values[0::2] - white) <= 4) and np.all(np.abs(values[1::2] - black) <= 4), values


def test_minified_checker_averages_to_its_mean(make_engine):
    # a one-texel 256 x 256 checker on the same 1 m plane covers 60 pixels: about 4 texels per
    # pixel, where one bilinear lookup would alias; the mip level of about a texel per pixel
    # holds the linear mean, 0.5: diffuse 0.96 x 0.5 + specular 0.01 of the light
    def place(world):
        checker = (np.indices((256, 256)).sum(0) % 2 * 255).astype(np.uint8)
        tex = world.add_texture(cressim.Texture(np.ascontiguousarray(checker[..., None].repeat(3, 2))))
        e = world.create_entity(env=0, name="floor")
        e.add(cressim.Transform())
        e.add(cressim.Renderable(world.add_mesh(cressim.Mesh.plane(0.5)), color=(1, 1, 1, 1), roughness=1.0,
                                 texture=tex))
        light(world, rotation=DOWN, intensity=1.0)

    rgb = render(make_engine, place, fov=30)
    inside = rgb[12:52, 12:52, 0]  # the plane spans pixels 2..61
    assert np.abs(inside - srgb(0.49)).max() <= 4, (inside.min(), inside.max(), srgb(0.49))


TILT = math.radians(30)


def normal_map(world, x, y):
    """A uniform normal map of the tangent-space normal (x, y, sqrt(1 - x^2 - y^2))."""
    m = np.array([x, y, math.sqrt(1 - x * x - y * y)])
    return world.add_texture(cressim.Texture(np.full((4, 4, 3), np.round((m + 1) / 2 * 255), dtype=np.uint8)))


def lit_plane(make_engine, light_dir, *, tilt=(0.0, 0.0), rotation=(0, 0, 0, 1), scale=1.0):
    # a matte plane seen from above under a directional light from light_dir (no ambient)
    def place(world):
        e = world.create_entity(env=0, name="floor")
        e.add(cressim.Transform(rotation=rotation))
        nm = normal_map(world, *tilt) if tilt != (0.0, 0.0) else -1
        e.add(cressim.Renderable(world.add_mesh(cressim.Mesh.plane(0.5)), color=(1, 1, 1, 1), roughness=1.0,
                                 normal_map=nm, normal_scale=scale))
        light(world, position=tuple(light_dir), look_at=(0, 0, 0), intensity=1.0)

    return render(make_engine, place)[S // 2 - 1:S // 2 + 1, S // 2 - 1:S // 2 + 1, 0]


def test_normal_map_tilts_the_shading_normal_like_geometry(make_engine):
    # at the image centre (view straight down) a flat plane whose map tilts its normal by 30 deg
    # shades as the plane itself tilted by 30 deg: x of the map along +u (world +x), y toward the
    # image's top (world +y on Mesh.plane, where v grows toward -y)
    s, c = math.sin(TILT), math.cos(TILT)
    about_y = (0, math.sin(TILT / 2), 0, math.cos(TILT / 2))  # normal to (s, 0, c)
    about_y_back = (0, -math.sin(TILT / 2), 0, math.cos(TILT / 2))  # (-s, 0, c)
    about_x = (-math.sin(TILT / 2), 0, 0, math.cos(TILT / 2))  # (0, s, c)
    toward_x, toward_y = (s, 0, c), (0, s, c)
    facing = lit_plane(make_engine, toward_x, tilt=(s, 0.0))
    assert np.abs(facing - lit_plane(make_engine, toward_x, rotation=about_y)).max() <= 2
    away = lit_plane(make_engine, toward_x, tilt=(-s, 0.0))
    assert np.abs(away - lit_plane(make_engine, toward_x, rotation=about_y_back)).max() <= 2
    assert facing.min() - away.max() > 20  # n.l 1 against 0.5: the map's x has a direction
    up = lit_plane(make_engine, toward_y, tilt=(0.0, s))
    assert np.abs(up - lit_plane(make_engine, toward_y, rotation=about_x)).max() <= 2
    assert np.abs(up - facing).max() <= 2
    # normal_scale 0: as without a map
    assert np.abs(lit_plane(make_engine, toward_x, tilt=(s, 0.0), scale=0.0) - lit_plane(make_engine, toward_x)).max() <= 1


def test_normal_map_errors_name_the_entity(make_engine):
    def world_with(normal_map):
        world = cressim.World(cressim.SceneLayout(1))
        tex = world.add_texture(cressim.io.checker_texture())
        e = world.create_entity(env=0, name="floor")
        e.add(cressim.Transform())
        e.add(cressim.Renderable(world.add_mesh(cressim.Mesh.plane(0.5)), texture=tex, normal_map=normal_map))
        return world

    with pytest.raises(Exception, match="floor.*Renderable.normal_map 0 is also used as a colour texture"):
        make_engine(world_with(0)).prepare()
    with pytest.raises(Exception, match="floor.*Renderable.normal_map 5 is not a texture of the world"):
        make_engine(world_with(5)).prepare()


def test_shadow_and_camera_groups_split_without_changing_images(make_engine, monkeypatch):
    # three envs with shadows and cameras, in targets of one layer each or all in one
    def images():
        world = cressim.World(cressim.SceneLayout(3))
        plane, box = world.add_mesh(cressim.Mesh.plane(2.0)), world.add_mesh(cressim.Mesh.box((0.15, 0.15, 0.15)))
        for env in range(3):
            world.create_entity(env=env).add(cressim.EnvironmentLight(sky=(0, 0, 0), ground=(0, 0, 0)))
            f = world.create_entity(env=env)
            f.add(cressim.Transform())
            f.add(cressim.Renderable(plane))
            b = world.create_entity(env=env)
            b.add(cressim.Transform(position=(0.1 * env, 0, 0.5)))
            b.add(cressim.Renderable(box))
            s = world.create_entity(env=env)
            s.add(cressim.Transform(position=(0, 0, 1), rotation=_quat_look_at((0, 0, 1), (1, 0, 0))))
            s.add(cressim.Light(shadows=True, shadow_extent=1.5, shadow_resolution=64))
            c = world.create_entity(env=env)
            c.add(cressim.Transform(position=(0, 0, 2), rotation=DOWN))
            c.add(cressim.Camera(width=32, height=32, fov_y=60))
        engine = make_engine(world)
        engine.prepare()
        engine.upload_world()
        engine.step_visual_sensors()
        engine.end_frame()
        groups = engine.cameras["group"]
        return len(set(groups)), np.concatenate([engine.buffer(f"camera{g}.rgb").read() for g in sorted(set(groups))])

    n1, whole = images()
    monkeypatch.setenv("CRESSIM_MAX_LAYERS", "1")
    n3, split = images()
    assert (n1, n3) == (1, 3) and np.array_equal(whole, split)
    assert (whole[:, :, :, 0] == 0).any() and not np.array_equal(whole[0], whole[2])  # shadows, per env
