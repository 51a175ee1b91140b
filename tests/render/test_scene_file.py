"""Scene files and `cressim render`: the example scene loads and renders to PNG files; bad
fields are reported with file, line and field; the PNG writer round-trips."""
import numpy as np
import pytest

import cressim
from cressim import io
from cressim.cli import main
from cressim.scene_file import SceneFileError, load_scene

DEMO = "scenes/render_demo.yaml"


def test_png_round_trip(tmp_path):
    img = np.random.default_rng(0).integers(0, 256, (7, 5, 3), dtype=np.uint8)
    io.save_png(tmp_path / "a.png", img)
    assert np.array_equal(io.read_png(tmp_path / "a.png")[..., :3], img)
    grey = img[..., 0]
    io.save_png(tmp_path / "g.png", grey)
    back = io.read_png(tmp_path / "g.png")
    assert np.array_equal(back if back.ndim == 2 else back[..., 0], grey)


def test_example_scene_loads_every_kind():
    world = load_scene(DEMO)
    assert world.layout.num_envs == 2
    names = [world.entity(e).name for e in range(world.entity_count) if world.entity(e).env == 0]
    assert names == ["environment", "ground", "crate", "ball", "ring", "sun", "lamp", "spot", "camera"]
    cam = world.entity(names.index("camera"))
    assert cam.has(cressim.Camera) and world.entity(names.index("ground")).has(cressim.Collider)


def test_cressim_render_writes_images(tmp_path, capsys):
    assert main(["render", DEMO, "--out", str(tmp_path)]) == 0
    files = sorted(p.name for p in tmp_path.iterdir())
    assert files == ["env0_camera_depth.exr", "env0_camera_depth.npy", "env0_camera_depth.png",
                     "env0_camera_rgb.png", "env0_camera_segmentation.png"]
    rgb = io.read_png(tmp_path / "env0_camera_rgb.png")
    assert rgb.shape == (240, 320, 3) and rgb.std() > 10  # a picture, not a flat colour
    depth = np.load(tmp_path / "env0_camera_depth.npy")
    assert depth.shape == (240, 320) and 0.4 < depth[depth > 0].min() < depth.max() < 3.0
    seg = io.read_png(tmp_path / "env0_camera_segmentation.png")
    colours = {tuple(c) for c in seg.reshape(-1, 3)}
    assert len(colours) >= 5  # ground, crate, ball, ring (+ edges' background, black)


@pytest.mark.parametrize("text, line, message", [
    ("envs: 1\nentities:\n  - name: a\n    renderable: {mesh: nothing}\n", "4:24",
     "entities[0].renderable.mesh: no mesh 'nothing'"),
    ("envs: 1\nentities:\n  - name: a\n    transform: {position: [0, 1]}\n", "4:27",
     "entities[0].transform.position: expected 3 numbers, got 2"),
    ("envs: 1\nentities:\n  - name: a\n    light: {kind: lamp}\n", "4:12", "entities[0].light: Light kind 'lamp'"),
    ("envs: two\n", "1:7", "envs: expected an integer"),
    ("envs: 1\nentities:\n  - name: a\n    renderable: {mesh: {sphere: {radius: 0.1}}, normal_map: bumps}\n", "4:61",
     "entities[0].renderable.normal_map: no texture 'bumps'"),
    ("envs: 1\nentities:\n  - name: a\n\n    camra: {width: 8}\n", "5:5",
     "entities[0].camra: unknown field 'camra'"),
])
def test_errors_name_file_line_and_field(tmp_path, text, line, message):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(SceneFileError) as e:
        load_scene(path)
    assert str(e.value).startswith(f"{path}:{line}: {message}"), str(e.value)


def test_materials_carry_normal_maps(tmp_path):
    path = tmp_path / "bumpy.yaml"
    path.write_text("envs: 1\ntextures:\n  colour: {checker: {size: 8, squares: 2}}\n"
                    "  bumps: {checker: {size: 8, squares: 4}}\n"
                    "materials:\n  bumpy: {texture: colour, normal_map: bumps, normal_scale: 0.5}\n"
                    "entities:\n  - name: a\n    renderable: {mesh: {plane: {half_size: 1}}, material: bumpy}\n")
    r = load_scene(path).entity(0).renderable
    assert (r.texture, r.normal_map, r.normal_scale) == (0, 1, 0.5)


def test_glb_carries_its_colour_and_normal_maps(tmp_path):
    import trimesh
    from PIL import Image

    box = trimesh.creation.box()
    material = trimesh.visual.material.PBRMaterial(
        baseColorTexture=Image.fromarray(np.full((4, 4, 3), (200, 10, 10), np.uint8)),
        normalTexture=Image.fromarray(np.full((4, 4, 3), (128, 200, 230), np.uint8)))
    box.visual = trimesh.visual.TextureVisuals(uv=np.zeros((len(box.vertices), 2)), material=material)
    box.export(tmp_path / "box.glb")
    colour, normals = (io.load_mesh_texture(tmp_path / "box.glb", which) for which in ("color", "normal"))
    assert tuple(colour.image[0, 0]) == (200, 10, 10, 255) and tuple(normals.image[3, 3]) == (128, 200, 230, 255)
    assert io.load_mesh_texture("scenes/meshes/torus.obj", "normal") is None
    with pytest.raises(ValueError, match="which='bump'"):
        io.load_mesh_texture(tmp_path / "box.glb", "bump")


def test_mesh_file_loads_through_trimesh():
    mesh = io.load_mesh("scenes/meshes/torus.obj")
    assert mesh.triangle_count == 576 and mesh.vertex_count > 0
