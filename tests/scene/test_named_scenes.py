"""The named surgical scenes (scenes/*.yaml, docs/scenes.md) on lavapipe: each loads, prepares,
uploads and steps 30 frames with no NaN and no health event; the segmentation ids its header
lists are distinct and exactly the ones its camera sees, and its particle count is the header's.
Then what each is for: the flap lies on the table under the tool with its far edge held, the
blood stays in the basin while the bleeding source adds to it, the probe images the phantom's
cyst dark and its lesion bright, the liver for cautery carries heat at body temperature, and the
continuum robot bends by its tendons."""
import re
from pathlib import Path

import numpy as np
import pytest

from cressim.scene_file import load_scene

SCENES = Path(__file__).resolve().parents[2] / "scenes"
TABLE_TOP = 0.15
FRAMES = 30


def header(name):
    """{segmentation id: what} and the particle count per env, from the file's header comment."""
    text = (SCENES / f"{name}.yaml").read_text()
    ids = re.search(r"^# Segmentation ids: (.*)\.$", text, re.M).group(1)
    labels = {}
    for item in ids.split(", "):
        number, label = item.split(" ", 1)
        labels[int(number)] = label.split(" (")[0]
    count = int(re.search(r"^# Particles per env: ([\d,]+)", text, re.M).group(1).replace(",", ""))
    return labels, count


def run(make_engine, name):
    """The scene after FRAMES physics frames and one camera frame: engine, world, rest positions."""
    world = load_scene(SCENES / f"{name}.yaml")
    engine = make_engine(world)
    engine.prepare()
    engine.upload_world()
    rest = engine.buffer("particles.positions").read().copy()
    for _ in range(FRAMES):
        engine.step_physics()
        engine.end_frame()
    engine.step_visual_sensors()
    engine.end_frame()
    return engine, world, rest


def objects(engine, world):
    """name -> (first particle, count) of each particle object."""
    m = engine.particle_mapping
    return {world.entity(int(e)).name: (int(o), int(c))
            for e, o, c in zip(m["object_entity"], m["object_offset"], m["object_count"])}


@pytest.mark.parametrize("name", ["tissue_retraction", "blood_suction", "ultrasound_phantom", "cautery",
                                  "continuum_robot", "suture_pad"])
def test_scene_steps_and_shows_its_documented_ids(make_engine, name):
    labels, count = header(name)
    engine, _, _ = run(make_engine, name)
    positions = engine.buffer("particles.positions").read()
    assert np.isfinite(positions).all() and np.isfinite(engine.buffer("particles.velocities").read()).all()
    assert engine.health_events == 0
    assert len(positions) == count and 300 <= count <= 2000  # small enough for a CPU rasterizer
    assert len(set(labels.values())) == len(labels) and {"table", "tissue"} <= set(labels.values())
    seen = set(np.unique(engine.buffer("camera0.segmentation").read()[0]).tolist()) - {0}
    assert seen == set(labels)


def test_the_flap_lies_under_the_tool_with_its_far_edge_held(make_engine):
    engine, world, rest = run(make_engine, "tissue_retraction")
    first, count = objects(engine, world)["flap"]
    p, p0 = engine.buffer("particles.positions").read()[first:first + count], rest[first:first + count]
    assert np.allclose(p0[:, :3].max(0) - p0[:, :3].min(0), (0.06, 0.04, 0.006), atol=1e-6)
    assert len(np.unique(p0[:, 2].round(6))) >= 3  # at least two cells through the thickness
    edge = p0[:, 1] > 0.02 - 1e-6
    assert (p[:, 3] == 0).sum() == edge.sum() == 13 * 3 and (p[edge, 3] == 0).all()  # the far edge, held
    assert np.array_equal(p[edge, :3], p0[edge, :3])
    assert abs(p[:, 2].min() - 0.0015 - TABLE_TOP) < 5e-4  # resting on the table (radius 1.5 mm)
    assert np.abs(p[:, :2].mean(0)).max() < 0.011  # centred under the RCM at (0, 0, 0.3)


def test_the_blood_stays_in_the_basin_as_the_source_bleeds(make_engine):
    engine, world, _ = run(make_engine, "blood_suction")
    first, count = objects(engine, world)["blood"]
    k = list(objects(engine, world)).index("blood")
    assert int(engine.buffer("particles.emitted").read()[k]) == 288 + 4 * FRAMES
    active = (engine.buffer("particles.phases").read()[first:first + count, 3] & 1) > 0
    blood = engine.buffer("particles.positions").read()[first:first + count][active]
    basin = 0.154  # the basin's frame: pocket walls' inner particles at x, y = +-0.024, floor at z = 0.006
    assert len(blood) == 288 + 4 * FRAMES
    assert (np.abs(blood[:, :2]) < 0.024).all() and (blood[:, 2] > basin + 0.006).all()


def test_the_probe_images_the_cyst_dark_and_the_lesion_bright(make_engine):
    engine, _, _ = run(make_engine, "ultrasound_phantom")
    engine.step_simulation_sensors()
    engine.end_frame()
    image = engine.buffer("ultrasound0.image").read()[0]  # 128 x 128: 35 mm deep, 38.4 mm across
    assert np.isfinite(image).all()

    def at(x, depth, half=5):
        """The mean around the pixel of lateral x and depth (m) below the face."""
        row, col = int(depth / 0.035 * 128), int((x + 0.0192) / 0.0384 * 128)
        return image[row - half:row + half + 1, col - half:col + half + 1].mean()

    background = image[10:30, 10:118].mean()  # 3-8 mm deep, speckle only
    assert background > 0.1
    assert at(0.006, 0.014) < 0.1 * background  # the anechoic cyst (5 mm)
    assert at(-0.009, 0.019, half=3) > 1.3 * background  # the hyperechoic lesion (3 mm)


def test_the_liver_for_cautery_carries_heat_at_body_temperature(make_engine):
    engine, world, _ = run(make_engine, "cautery")
    first, count = objects(engine, world)["liver"]
    assert (engine.buffer("particles.heat_capacities").read()[first:first + count] > 0).all()
    np.testing.assert_allclose(engine.buffer("particles.temperatures").read(), 310.15, atol=1e-4)  # nothing heats it
    assert not engine.buffer("particles.damage").read().any()


def test_the_continuum_robot_bends_toward_its_pulled_tendon(make_engine):
    from cressim.tendons import TendonDrive

    engine, world, rest = run(make_engine, "continuum_robot")
    first, count = objects(engine, world)["robot"]
    tip = first + count - 1
    assert np.allclose(engine.buffer("particles.positions").read()[tip, :3], rest[tip, :3], atol=1e-4)  # held straight
    drive = TendonDrive(engine)
    assert drive.rest_lengths.shape == (1, 4)
    drive.pull([0.002, 0, -0.002, 0])  # 0.5 rad toward tendon 0 (constant curvature: d / r)
    for _ in range(120):
        engine.step_physics()
        engine.end_frame()
    moved = engine.buffer("particles.positions").read()[tip, :3] - rest[tip, :3]
    # a 0.1 m arc turned 0.5 rad from its clamp swings its tip about 24 mm sideways and 4 mm up
    assert 0.018 < np.linalg.norm(moved[:2]) < 0.03 and moved[2] > 0.002
    assert engine.health_events == 0
