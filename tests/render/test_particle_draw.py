"""Particles drawn by the rasterizer straight from the physics buffers (both rasterizers):
soft-body surfaces, strand tubes and screen-space fluids against the geometry they come from.
Camera: 64x64, fov 50, at y = -1 looking along +y (particle_render_scenes.py)."""
import numpy as np
import pytest

import cressim
from cressim import io
from cressim.render_scene import render as render_file
from cressim.scene_file import load_scene

from .particle_render_scenes import F, S, fluid_block, lattice, project, render, soft_cube, start, world_with_camera

pytestmark = pytest.mark.usefixtures("raster")


def test_soft_cube_projects_to_its_front_face(make_engine):
    # the surface runs through the particle centres: a 0.2 m cube whose front face is 0.9 m away
    world = world_with_camera()
    cube = soft_cube(world)
    engine = start(world, make_engine)
    rgb, depth, seg = render(engine)
    mask = seg[0] == cube.id + 1
    half = F * 0.1 / 0.9  # pixels; the face is centred on the image
    centres = np.arange(S) + 0.5
    inside = np.abs(centres - S / 2) <= half
    expected = inside[:, None] & inside[None, :]  # pixel centres inside the projected face
    assert (mask != expected).sum() <= 2 and expected.sum() == 256
    assert abs(depth[0, S // 2, S // 2] - 0.9) < 1e-3  # metres, at the centre
    assert rgb[0][mask][:, :3].mean() > 20  # lit, not black


def test_soft_body_image_follows_its_particles_as_it_falls(make_engine):
    world = world_with_camera()
    cube = soft_cube(world, centre=(0, 0, 0.35), cells=2)
    engine = start(world, make_engine, substeps=4, particle_iterations=8)
    _, _, before = render(engine)
    _, _, after = render(engine, physics_frames=30)  # falls and lands on the ground
    assert (before != after).any()
    # the drawn silhouette's box matches the projected particles' box within 1.5 pixels
    uv, _ = project(engine.buffer("particles.positions").read()[:, :3])
    rows, cols = np.nonzero(after[0] == cube.id + 1)
    assert abs(rows.min() - uv[:, 1].min()) < 1.5 and abs(rows.max() + 1 - uv[:, 1].max()) < 1.5
    assert abs(cols.min() - uv[:, 0].min()) < 1.5 and abs(cols.max() + 1 - uv[:, 0].max()) < 1.5
    assert rows.mean() > np.nonzero(before[0] == cube.id + 1)[0].mean() + 5  # lower in the image


def test_soft_bodies_stay_in_their_env_and_take_their_material(make_engine):
    world = world_with_camera(envs=2)
    soft_cube(world, env=0, color=(0.1, 0.1, 0.9, 1.0), segmentation_id=42)
    engine = start(world, make_engine)
    rgb, _, seg = render(engine)
    assert (seg[0] == 42).sum() > 100 and (seg[1] == 42).sum() == 0
    blue = rgb[0][seg[0] == 42][:, :3].mean(0)
    assert blue[2] > 2 * blue[0]


def test_fluid_surface_depth_within_a_particle_radius(make_engine):
    # a block of fluid particles (r 2 cm, spacing 4 cm) at rest; its front surface is the front
    # layer's centres minus r: y = -0.05 - 0.02, so 0.93 m from the eye
    r = 0.02
    world = world_with_camera(ground=False)
    water = fluid_block(world, counts=(6, 3, 4), r=r, origin=(-0.1, -0.05, 0.02), budget=200)
    engine = start(world, make_engine)
    rgb, depth, seg = render(engine)
    (u, v), _ = project([0.0, -0.07, 0.08])
    u, v = int(u), int(v)
    assert seg[0, v, u] == water.id + 1
    assert abs(depth[0, v, u] - 0.93) < r
    red = rgb[0][seg[0] == water.id + 1][:, :3].mean(0)
    assert red[0] > 2 * red[1] and red[0] > 2 * red[2]  # blood by default
    # the 128 inactive slots sit at the origin, which is in view: nothing is drawn there
    (u0, v0), _ = project([0.0, 0.0, 0.0])
    assert seg[0, int(v0) - 2, int(u0)] != water.id + 1 or depth[0, int(v0) - 2, int(u0)] < 1.0 - 0.05
    fluid = seg[0] == water.id + 1
    lo, _ = project([[-0.1 - r, -0.07, 0.14 + r], [0.1 + r, -0.07, 0.0]])
    rows, cols = np.nonzero(fluid)
    assert rows.max() < lo[1, 1] + 2 and cols.min() > lo[0, 0] - 2 and cols.max() < lo[1, 0] + 2


def test_fluid_stays_in_its_env_and_needs_no_depth_product(make_engine):
    # env 0 has the fluid, env 1 none; a segmentation-only camera (the occlusion test then uses
    # a depth stand-in) gives the same ids as a full one
    segs = []
    for products in (["rgb", "depth", "segmentation"], ["segmentation"]):
        world = world_with_camera(envs=2, products=products)
        water = fluid_block(world, env=0, counts=(4, 2, 3))
        soft_cube(world, env=1, centre=(0.3, 0, 0.1), half=0.05)
        engine = start(world, make_engine)
        engine.step_visual_sensors()
        engine.end_frame()
        segs.append(engine.buffer("camera0.segmentation").read().copy())
    full, only = segs
    assert (full[0] == water.id + 1).sum() > 50 and not (full[1] == water.id + 1).any()
    assert np.array_equal(full, only)


def test_fluid_is_hidden_behind_nearer_surfaces(make_engine):
    world = world_with_camera(ground=False)
    water = fluid_block(world, counts=(4, 2, 4), origin=(-0.06, 0.2, 0.02))
    cube = soft_cube(world, centre=(0, -0.2, 0.1))  # in front, covering the fluid
    engine = start(world, make_engine)
    _, _, seg = render(engine)
    assert (seg[0] == cube.id + 1).sum() > 100 and (seg[0] == water.id + 1).sum() == 0


def test_strand_pixels_follow_its_particles(make_engine):
    world = world_with_camera()
    points = lattice((11, 1, 1), 0.04, (-0.2, 0.0, 0.25))
    thread = world.create_entity(env=0, name="thread")
    thread.add(cressim.Strand(points, fixed=[0], radius=0.02, bend_compliance=1e2, damping=5.0))
    engine = start(world, make_engine, substeps=4, particle_iterations=8)
    _, _, seg = render(engine)
    uv, z = project(points)
    # straight: its width on screen is the tube's diameter, 2 r F / z, within 1.5 pixels
    assert abs((seg[0] == thread.id + 1)[:, int(uv[5, 0])].sum() - 2 * 0.02 * F / z[5]) < 1.5
    for frames in (0, 10):  # then swinging down from its fixed end (still above the ground, z = 0)
        _, _, seg = render(engine, physics_frames=frames)
        uv, _ = project(engine.buffer("particles.positions").read()[:, :3])
        mask = seg[0] == thread.id + 1
        for k in range(1, 11):  # each particle's pixel is the thread's
            assert mask[int(uv[k, 1]), int(uv[k, 0])], (frames, k)
    assert uv[10, 1] - project(points)[0][10, 1] > 5  # it did swing


PARTICLE_SCENE = """\
materials:
  wet: {color: [0.7, 0.3, 0.3], roughness: 0.3}
entities:
  - name: ground
    collider: {shapes: [{plane: {}}]}
  - name: tissue
    transform: {position: [-0.1, 0.0, 0.1]}
    soft_body: {box: {half_extents: [0.06, 0.06, 0.06], cells: [2, 2, 2]}, radius: 0.02}
    material: wet
  - name: blood
    fluid: {block: {counts: [4, 3, 2], spacing: 0.04, origin: [0.05, -0.05, 0.02]}, radius: 0.02}
    material: {color: [0.4, 0.02, 0.02], segmentation_id: 9}
  - name: thread
    strand: {line: {start: [-0.2, 0.0, 0.3], end: [0.2, 0.0, 0.3], count: 9}, radius: 0.01, fixed: [0, 8]}
  - name: camera
    transform: {position: [0, -1, 0.1], look_at: [0, 0, 0.1]}
    camera: {width: 64, height: 64, fov_y: 50}
"""


def test_scene_file_particles_render(tmp_path):
    # soft_body / fluid / strand / material entries of a scene file, through `cressim render`
    scene = tmp_path / "particles.yaml"
    scene.write_text(PARTICLE_SCENE)
    world = load_scene(scene)
    assert [world.entity(e).has(cressim.Material) for e in range(world.entity_count)] == [False, True, True, False, False]
    render_file(scene, tmp_path, steps=2)
    seg = io.read_png(tmp_path / "env0_camera_segmentation.png")[..., :3]
    assert len(np.unique(seg.reshape(-1, 3), axis=0)) == 4  # background, tissue, blood, thread
    scene.write_text(PARTICLE_SCENE.replace(", cells: [2, 2, 2]", ""))
    with pytest.raises(ValueError, match=r"particles.yaml:8:22: entities\[1\].soft_body.box: box needs 'cells'"):
        load_scene(scene)


def test_strand_seen_end_on_shows_its_cap(make_engine):
    # a tube along the optical axis: the centre ray would pass down an open tube; the cap closes
    # it at the near end particle (0.8 m away), and the disc is the tube's cross-section
    world = world_with_camera(ground=False)
    points = lattice((1, 9, 1), 0.05, (0.0, -0.2, 0.1))
    thread = world.create_entity(env=0, name="thread")
    thread.add(cressim.Strand(points, radius=0.05))
    engine = start(world, make_engine)
    _, depth, seg = render(engine)
    mask = seg[0] == thread.id + 1
    assert mask[S // 2, S // 2] and abs(depth[0, S // 2, S // 2] - 0.8) < 1e-3
    octagon = 2 * np.sqrt(2) * (0.05 * F / 0.8) ** 2  # area of the 8-sided ring, pixels
    assert abs(mask.sum() / octagon - 1) < 0.1
