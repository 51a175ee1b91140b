"""Scene-file fields for surgical scenes (cressim/scene_file.py): soft bodies from .vtk/.msh
files, `fixed` regions, fluid emitters (bleeding sources), ultrasound probes and tissues. Each
works when written right and, written wrong, fails naming file:line and the field, in the loader
or at prepare() (the engine's AuthoringError carries the line the loader recorded)."""
import textwrap

import numpy as np
import pytest

import cressim
from cressim.scene_file import SceneFileError, load_scene

from vtk_files import vtk_lines


def write(tmp_path, text, name="scene.yaml"):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text).lstrip())
    return path


def prepared(make_engine, path):
    engine = make_engine(load_scene(path))
    engine.prepare()
    engine.upload_world()
    return engine


def loader_error(tmp_path, text):
    path = write(tmp_path, text)
    with pytest.raises(SceneFileError) as e:
        load_scene(path)
    return path, str(e.value)


def prepare_error(make_engine, tmp_path, text):
    path = write(tmp_path, text)
    with pytest.raises(cressim.AuthoringError) as e:
        make_engine(load_scene(path)).prepare()
    return path, e.value


def box_vtk(tmp_path, half=(0.02, 0.01, 0.005), cells=(2, 2, 1)):
    box = cressim.TetMesh.box(half, cells)
    (tmp_path / "meshes").mkdir(exist_ok=True)
    (tmp_path / "meshes/box.vtk").write_text("\n".join(vtk_lines(box.positions, box.tets, [10] * len(box.tets))))
    return box


def particles(engine, entity=0):
    """Positions (xyz, w inverse mass) of the particle object of `entity`."""
    m = engine.particle_mapping
    k = list(m["object_entity"]).index(entity)
    first, count = m["object_offset"][k], m["object_count"][k]
    return engine.buffer("particles.positions").read()[first:first + count]


# --- soft bodies from mesh files ---------------------------------------------------------------

def test_soft_body_from_a_vtk_file_is_scaled_into_the_entity_frame(tmp_path, make_engine):
    box = box_vtk(tmp_path)
    path = write(tmp_path, """
        entities:
          - name: flap
            transform: {position: [0, 0, 1]}
            soft_body: {mesh: meshes/box.vtk, scale: 2, radius: 0.002, youngs_modulus: 5e3}
        """)
    p = particles(prepared(make_engine, path))
    assert np.allclose(p[:, :3], 2 * box.positions + (0, 0, 1), atol=1e-6)
    assert (p[:, 3] > 0).all()  # elastic: every particle has mass from its tets


def test_soft_body_from_a_gmsh_file(tmp_path, make_engine):
    nodes = [(0, 0, 0), (0.01, 0, 0), (0, 0.01, 0), (0, 0, 0.01)]
    lines = ["$MeshFormat", "2.2 0 8", "$EndMeshFormat", "$Nodes", "4"]
    lines += [f"{i + 1} {x} {y} {z}" for i, (x, y, z) in enumerate(nodes)] + ["$EndNodes", "$Elements", "1",
                                                                             "1 4 0 1 2 3 4", "$EndElements"]
    (tmp_path / "tet.msh").write_text("\n".join(lines) + "\n")
    path = write(tmp_path, "entities:\n  - name: tet\n    soft_body: {mesh: tet.msh, radius: 0.001}\n")
    assert np.allclose(particles(prepared(make_engine, path))[:, :3], nodes)


@pytest.mark.parametrize("text, line, message", [
    ("""
     entities:
       - name: flap
         soft_body:
           mesh: meshes/box.vtk
           scale: -1
     """, "5:14", "entities[0].soft_body.scale: must be positive, got -1.0"),
    ("""
     entities:
       - name: flap
         soft_body:
           box: {half_extents: [0.01, 0.01, 0.01], cells: [1, 1, 1]}
           scale: 2
     """, "5:14", "entities[0].soft_body.scale: scale applies to mesh files"),
    ("""
     entities:
       - name: flap
         soft_body:
           mesh: meshes/box.obj
     """, "4:13", "entities[0].soft_body.mesh: cannot read the tet mesh: "),
    ("""
     entities:
       - name: flap
         soft_body: {box: {half_extents: [0.01, 0.01, 0.01], cells: [1, 1, 1]}, mesh: meshes/box.vtk}
     """, "3:16", "entities[0].soft_body: a soft_body needs one of: box, cylinder, mesh"),
])
def test_mesh_field_errors_name_the_line(tmp_path, text, line, message):
    box_vtk(tmp_path)
    (tmp_path / "meshes/box.obj").write_text("v 0 0 0\n")
    path, error = loader_error(tmp_path, text)
    assert error.startswith(f"{path}:{line}: {message}"), error


def test_a_malformed_mesh_file_names_both_lines(tmp_path):
    box_vtk(tmp_path)
    vtk = tmp_path / "meshes/box.vtk"
    lines = vtk.read_text().splitlines()
    lines[6] = "0.01 oops 0"
    vtk.write_text("\n".join(lines))
    path, error = loader_error(tmp_path, "entities:\n  - name: flap\n\n    soft_body: {mesh: meshes/box.vtk}\n")
    assert error.startswith(f"{path}:4:23: entities[0].soft_body.mesh: cannot read the tet mesh: "
                            f"{vtk}:7: POINTS: expected a number, got 'oops'"), error


# --- fixed regions -----------------------------------------------------------------------------

@pytest.mark.parametrize("fixed, expected", [
    ("{below: {axis: z, value: -0.005}}", lambda p: p[:, 2] < -0.004),
    ("{above: {axis: x, value: 0.02}}", lambda p: p[:, 0] > 0.019),
    ("{box: {center: [-0.02, -0.01, 0], half_extents: [0.001, 0.001, 0.01]}}",
     lambda p: (p[:, 0] < -0.019) & (p[:, 1] < -0.009)),
    ("[0, 3]", lambda p: np.isin(np.arange(len(p)), [0, 3])),
])
def test_fixed_regions_hold_the_particles_inside(tmp_path, make_engine, fixed, expected):
    box = box_vtk(tmp_path)
    path = write(tmp_path, f"""
        entities:
          - name: flap
            soft_body: {{mesh: meshes/box.vtk, radius: 0.002, fixed: {fixed}}}
        """)
    held = particles(prepared(make_engine, path))[:, 3] == 0  # inverse mass 0: clamped
    assert held.any() and np.array_equal(held, expected(box.positions))


def test_a_fixed_region_holds_strand_points(tmp_path, make_engine):
    path = write(tmp_path, """
        entities:
          - name: thread
            strand: {line: {start: [0, 0, 0.5], end: [0.3, 0, 0.5], count: 4}, fixed: {below: {axis: x, value: 0}}}
        """)
    assert np.array_equal(particles(prepared(make_engine, path))[:, 3] == 0, [True, False, False, False])


@pytest.mark.parametrize("fixed, line, message", [
    ("below: {axis: z, value: -0.5}", "6:9",
     "entities[0].soft_body.fixed: the region holds none of the 18 particles (entity frame: x [-0.02, 0.02]"),
    ("above: {axis: w, value: 0}", "6:23", "entities[0].soft_body.fixed.above.axis: expected x, y or z, got 'w'"),
    ("above: {axis: z, value: .nan}", "6:33", "entities[0].soft_body.fixed.above.value: must be finite, got nan"),
    ("box: {center: [0, 0, 0], half_extents: [0.01, 0, 0.01]}", "6:55",
     "entities[0].soft_body.fixed.box.half_extents[1]: must be positive, got 0.0"),
    ("box: {center: [0, 0, 0]}", "6:14", "entities[0].soft_body.fixed.box: box needs 'half_extents'"),
    ("below: {axis: z, value: 0}\nabove: {axis: z, value: 0}", "6:9", "entities[0].soft_body.fixed: give one region"),
    ("inside: {}", "6:9", "entities[0].soft_body.fixed.inside: unknown field 'inside'"),
])
def test_fixed_region_errors_name_the_line(tmp_path, fixed, line, message):
    box_vtk(tmp_path)
    path, error = loader_error(tmp_path, textwrap.dedent("""
        entities:
          - name: flap
            soft_body:
              mesh: meshes/box.vtk
              fixed:
        """) + textwrap.indent(fixed, " " * 8))
    assert error.startswith(f"{path}:{line}: {message}"), error


# --- fluid emitters (bleeding sources) ---------------------------------------------------------

def test_an_emitter_fills_its_budget_frame_by_frame(tmp_path, make_engine):
    path = write(tmp_path, """
        entities:
          - name: ground
            collider: {shapes: [{plane: {}}]}
          - name: blood
            fluid:
              block: {counts: [2, 2, 1], spacing: 0.01, origin: [0, 0, 0.005]}
              radius: 0.005
              rest_density: 1060
              budget: 16
              emit_rate: 4
              emit_width: 2
              emit_origin: [0, 0, 0.2]
              emit_velocity: [0, 0, -1]
        """)
    engine = prepared(make_engine, path)
    counts = []
    for _ in range(4):
        engine.step_physics()
        engine.end_frame()
        counts.append(int(engine.buffer("particles.emitted").read()[0]))
    assert counts == [8, 12, 16, 16]  # the block's 4, then 4 a frame up to the budget


def test_an_emitter_alone_is_a_fluid(tmp_path, make_engine):
    path = write(tmp_path, """
        entities:
          - name: blood
            fluid: {radius: 0.005, budget: 8, emit_rate: 2, emit_origin: [0, 0, 1]}
        """)
    engine = prepared(make_engine, path)
    engine.step_physics()
    engine.end_frame()
    assert int(engine.buffer("particles.emitted").read()[0]) == 2


@pytest.mark.parametrize("fields, line, message", [
    ("emit_rate: -1", "5:18", "entities[0].fluid.emit_rate: must be >= 0, got -1"),
    ("emit_rate: 2.5", "5:18", "entities[0].fluid.emit_rate: expected an integer, got 2.5"),
    ("emit_width: 0", "5:19", "entities[0].fluid.emit_width: must be >= 1, got 0"),
    ("emit_origin: [0, .inf, 0]", "5:24", "entities[0].fluid.emit_origin[1]: must be finite, got inf"),
    ("emit_velocity: [0, 0]", "5:22", "entities[0].fluid.emit_velocity: expected 3 numbers, got 2"),
    ("emit_rate: 2\nbudget: 20\nemit_velocity: [0, 0, 0]", "7:22", "entities[0].fluid.emit_velocity: must not be zero"),
    ("emit_rate: 2\nbudget: 8", "6:15", "entities[0].fluid.budget: an emitter needs a budget above the block's 8"),
    ("emit_rate: 2", "4:7", "entities[0].fluid: an emitter needs a budget above the block's 8"),
    ("budget: 3", "5:15", "entities[0].fluid.budget: must hold the block's 8 particles, got 3"),
])
def test_emitter_errors_name_the_line(tmp_path, fields, line, message):
    path, error = loader_error(tmp_path, textwrap.dedent("""
        entities:
          - name: blood
            fluid:
              block: {counts: [2, 2, 2], spacing: 0.01, origin: [0, 0, 0]}
        """) + textwrap.indent(fields, " " * 6))
    assert error.startswith(f"{path}:{line}: {message}"), error


def test_a_fluid_needs_particles_or_an_emitter(tmp_path):
    path, error = loader_error(tmp_path, "entities:\n  - name: blood\n    fluid: {radius: 0.01, budget: 10}\n")
    assert error.startswith(f"{path}:3:12: entities[0].fluid: a fluid needs 'block'"), error


# --- ultrasound --------------------------------------------------------------------------------

PROBE = textwrap.dedent("""
    entities:
      - name: tissue
        transform: {position: [0, 0, 0.02]}
        ultrasound_tissue:
          region: sphere
          size: [0.005]
          count: 300
          attenuation: 0.7
          seed: 3
      - name: probe
        transform: {rpy_deg: [0, 0, 0]}
        ultrasound_probe:
          kind: linear
          scanlines: 32
          line_spacing: 0.0005
          line_length: 0.04
          width: 48
          height: 64
          center_frequency: 5e6
          focal_depth: 0.02
          rf_output: false
    """)


def test_a_probe_images_a_rigid_tissue(tmp_path, make_engine):
    engine = make_engine(load_scene(write(tmp_path, PROBE)))
    engine.prepare()
    engine.upload_world()
    probes = engine.ultrasound_probes
    assert (probes["lines"], probes["width"], probes["height"], probes["scatterers"]) == (32, 48, 64, 300)
    engine.step_simulation_sensors()
    engine.end_frame()
    image = engine.buffer("ultrasound0.image").read()[0]
    assert np.isfinite(image).all()
    rows = np.flatnonzero(image.max(axis=1) > 0.1)  # the sphere: 15-25 mm deep of 40 mm, 64 rows
    assert 20 <= rows.min() and rows.max() <= 44


def test_a_tissue_region_is_placed_and_its_amplitudes_drawn_as_written(tmp_path, make_engine):
    path = write(tmp_path, """
        entities:
          - name: tissue
            ultrasound_tissue: {region: box, size: [0.001, 0.002, 0.003], center: [0.01, 0, 0.02], count: 200,
                                amplitude_mean: 2, amplitude_std: 0}
          - name: probe
            ultrasound_probe: {kind: linear, scanlines: 16, line_length: 0.04}
        """)
    scatterers = prepared(make_engine, path).buffer("ultrasound.scatterers").read()  # rigid: xyz, amplitude
    assert len(scatterers) == 200 and (scatterers[:, 3] == 2).all()
    offset = np.abs(scatterers[:, :3] - (0.01, 0, 0.02))
    assert (offset <= np.array([0.001, 0.002, 0.003]) + 1e-7).all() and (offset[:, 2] > 0.002).any()


def test_a_soft_tissue_carries_scatterers_in_its_tets_around_its_inclusion(tmp_path, make_engine):
    box_vtk(tmp_path, half=(0.01, 0.01, 0.01), cells=(2, 2, 2))
    path = write(tmp_path, """
        entities:
          - name: gel
            soft_body: {mesh: meshes/box.vtk, radius: 0.002}
            ultrasound_tissue:
              density: 2e8
              inclusions: [{center: [0, 0, 0], radius: 0.005}]
          - name: probe
            transform: {position: [0, 0, -0.01]}
            ultrasound_probe: {kind: linear, scanlines: 16, line_length: 0.02}
        """)
    probes = prepared(make_engine, path).ultrasound_probes
    expected = 2e8 * (0.02 ** 3 - 4 / 3 * np.pi * 0.005 ** 3)  # the cyst (amplitude 0) holds none
    assert probes["tets"] == 48 and abs(probes["scatterers"] - expected) < 4 * np.sqrt(expected)


@pytest.mark.parametrize("old, new, line, message", [
    ("kind: linear", "kind: convex", "13:13", "entities[1].ultrasound_probe.kind: expected linear or sector, got 'convex'"),
    ("scanlines: 32", "scanlines: 0", "14:18", "entities[1].ultrasound_probe.scanlines: must be >= 1, got 0"),
    ("focal_depth: 0.02", "focal_depth: .nan", "20:20", "entities[1].ultrasound_probe.focal_depth: must be finite"),
    ("rf_output: false", "rf_output: 1", "21:18", "entities[1].ultrasound_probe.rf_output: expected true or false"),
    ("width: 48", "depth: 48", "17:7", "entities[1].ultrasound_probe.depth: unknown field 'depth'"),
    ("region: sphere", "region: cube", "5:15", "entities[0].ultrasound_tissue.region: expected one of box, sphere"),
    ("size: [0.005]", "size: [0.005, 0.01]", "6:13", "entities[0].ultrasound_tissue.size: expected 1 numbers, got 2"),
    ("size: [0.005]", "size: [-0.005]", "6:14", "entities[0].ultrasound_tissue.size[0]: must be positive"),
    ("count: 300", "count: -3", "7:14", "entities[0].ultrasound_tissue.count: must be >= 0, got -3"),
    ("seed: 3", "seed: 3\n      inclusions: [{center: [0, 0, 0]}]", "10:20",
     "entities[0].ultrasound_tissue.inclusions[0]: an inclusion needs 'radius'"),
    ("seed: 3", "seed: 3\n      inclusions: [{center: [0, 0, 0], radius: 0}]", "10:48",
     "entities[0].ultrasound_tissue.inclusions[0].radius: must be positive, got 0"),
])
def test_ultrasound_loader_errors_name_the_line(tmp_path, old, new, line, message):
    path, error = loader_error(tmp_path, PROBE.replace(old, new))
    assert error.startswith(f"{path}:{line}: {message}"), error


@pytest.mark.parametrize("old, new, line, field, message", [
    ("center_frequency: 5e6", "center_frequency: -5e6", "19:25", "UltrasoundProbe.center_frequency",
     "must be positive, got -5e+06"),
    ("line_spacing: 0.0005", "line_spacing: 0", "15:21", "UltrasoundProbe.line_spacing", "must be positive, got 0"),
    ("attenuation: 0.7", "attenuation: -1", "8:20", "UltrasoundTissue.attenuation", "must be >= 0, got -1"),
    ("count: 300", "count: 0", "5:7", "UltrasoundTissue", "give either density or count"),
    ("seed: 3", "seed: 3\n      inclusions:\n        - center: [0, 0, 0]\n          radius: 0.001\n"
                "          amplitude_scale: -2", "13:28", "UltrasoundTissue.inclusions[0].amplitude_scale",
     "must be >= 0, got -2"),
])
def test_ultrasound_prepare_errors_name_the_line(tmp_path, make_engine, old, new, line, field, message):
    path, error = prepare_error(make_engine, tmp_path, PROBE.replace(old, new))
    assert error.source == f"{path}:{line}" and error.field == field, (error.source, error.field)
    assert message in str(error), str(error)


def test_a_strand_with_tendons_loads_as_a_continuum_robot(tmp_path, make_engine):
    path = write(tmp_path, """
        entities:
          - name: robot
            strand: {line: {start: [0, 0, 0.5], end: [0.1, 0, 0.5], count: 11}, fixed: [0, 1], radius: 0.0005,
                     youngs_modulus: 50e9, density: 6450}
            tendons: {disks: {every: 3}, holes: [[0.004, 0], [-0.004, 0]], stiffness: 2000}
        """)
    engine = prepared(make_engine, path)
    tendons = engine.buffer("particles.tendons").read()
    assert len(tendons) == 2 and np.allclose(tendons[:, 2].view(np.float32), 0.1, atol=1e-6)  # rest lengths
    assert tendons[0, 3].view(np.float32) == pytest.approx(0.1 / 2000)  # compliance L / EA
    disks = engine.buffer("particles.tendon_disks").read()[:, 0]
    assert disks.tolist() == [0, 3, 6, 9, 10]  # every third particle and the tip


@pytest.mark.parametrize("tendons, line, message", [
    ("{disks: [0, 12], holes: [[0.004, 0]]}", 4, "Tendons.disks[1] names particle 12 of the Strand's 11"),
    ("{disks: {every: 2}, holes: [[0.004]]}", 4, "entities[0].tendons.holes[0]: expected 2 numbers, got 1"),
    ("{disks: {each: 2}, holes: [[0.004, 0]]}", 4, "entities[0].tendons.disks.each: unknown field 'each'"),
    ("{holes: [[0.004, 0]]}", 4, "entities[0].tendons: tendons needs 'disks'"),
])
def test_tendon_errors_name_the_line(tmp_path, make_engine, tendons, line, message):
    text = f"""
        entities:
          - name: robot
            strand: {{line: {{start: [0, 0, 0.5], end: [0.1, 0, 0.5], count: 11}}, youngs_modulus: 50e9}}
            tendons: {tendons}
        """
    path = write(tmp_path, text)
    with pytest.raises((SceneFileError, cressim.AuthoringError)) as e:
        make_engine(load_scene(path)).prepare()
    assert f"{path}:{line}" in str(e.value) and message in str(e.value)
