"""Scene files keep file:line in every error: those the loader finds (an integer written 2.7, a
fluid spacing of 0) and those prepare() finds later (cressim/scene_file.py records where each
entity and field was written; the engine's AuthoringError starts with it)."""
import textwrap

import pytest

import cressim
from cressim.scene_file import SceneFileError, load_scene


def write(tmp_path, text):
    path = tmp_path / "scene.yaml"
    path.write_text(textwrap.dedent(text).lstrip())
    return path


@pytest.mark.parametrize("text, line, message", [
    ("""
     entities:
       - name: tissue
         soft_body:
           box: {half_extents: [0.1, 0.1, 0.1], cells: [2.7, 2, 2]}
     """, "4:52", "entities[0].soft_body.box.cells[0]: expected an integer, got 2.7"),
    ("""
     entities:
       - name: blood
         fluid:
           block:
             counts: [2, 2, 2]
             spacing: 0
             origin: [0, 0, 0]
     """, "6:18", "entities[0].fluid.block.spacing: must be positive, got 0.0"),
    ("""
     entities:
       - name: blood
         fluid:
           block: {counts: [2, 2.5, 2], spacing: 0.1, origin: [0, 0, 0]}
     """, "4:27", "entities[0].fluid.block.counts[1]: expected an integer, got 2.5"),
])
def test_loader_errors_keep_the_line(tmp_path, text, line, message):
    path = write(tmp_path, text)
    with pytest.raises(SceneFileError) as e:
        load_scene(path)
    assert str(e.value).startswith(f"{path}:{line}: {message}"), str(e.value)


@pytest.mark.parametrize("text, line, field, message", [
    ("""
     envs: 2
     entities:
       - name: ground
         collider: {shapes: [{plane: {}}]}
       - name: ball
         rigid_body: {mass: 1}
         collider:
           shapes: [{sphere: {radius: 0.05}}]
           restitution: 5
     """, "9:20", "Collider.restitution", "Collider.restitution must be in [0, 1], got 5"),
    ("""
     entities:
       - name: ball
         rigid_body:
           density: 500
           mass: -1
         collider: {shapes: [{sphere: {radius: 0.05}}]}
     """, "5:13", "RigidBody.mass", "RigidBody.mass must be >= 0"),
    ("""
     entities:
       - name: ball
         rigid_body: {mass: 1}
         collider:
           shapes:
             - sphere: {radius: 0.05}
             - box:
                 half_extents: [0.1, 0.1, .inf]
     """, "8:27", "Collider.shapes[1].size[2]", "Collider.shapes[1].size[2] must be finite, got inf"),
    ("""
     entities:
       - name: tissue
         soft_body:
           box: {half_extents: [0.1, 0.1, 0.1], cells: [1, 1, 1]}
           fixed: [999]
     """, "5:14", "SoftBody.fixed", "SoftBody.fixed names particle 999 of 8"),
    ("""
     materials:
       shiny:
         color: [1, 0, 0]
         metallic: 2
     entities:
       - name: crate
         renderable: {mesh: {box: {half_extents: [0.1, 0.1, 0.1]}}, material: shiny}
     """, "4:15", "Renderable.metallic", "Renderable.metallic must be in [0, 1], got 2"),
    ("""
     layout: {max_cameras_per_env: 1}
     entities:
       - name: cam0
         camera: {width: 8, height: 8}
       - name: cam1
         camera: {width: 8, height: 8}
     """, "5:5", "", "env 0 has more cameras than SceneLayout.max_cameras_per_env = 1"),
])
def test_prepare_errors_keep_the_line(tmp_path, text, line, field, message):
    path = write(tmp_path, text)
    world = load_scene(path)
    with pytest.raises(cressim.AuthoringError) as e:
        cressim.Engine(world).prepare()
    assert e.value.source == f"{path}:{line}" and e.value.field == field
    assert str(e.value).startswith(f"{path}:{line}: entity "), str(e.value)
    assert message in str(e.value), str(e.value)


def test_cressim_render_reports_the_line(tmp_path, capsys):
    from cressim.cli import main

    path = write(tmp_path, """
        entities:
          - name: lamp
            light: {intensity: -3}
        """)
    assert main(["render", str(path), "--out", str(tmp_path)]) == 2
    assert f"{path}:3:24: entity 0 'lamp' in env 0: Light.intensity must be >= 0, got -3" in capsys.readouterr().err
