"""Probes of different sizes in one world, and the uint8 image.

Probes that share scanlines, IQ samples per line, image size and RF output form one output group
(ultrasound<g>.*, a layer per probe, envs in order); others get groups of their own. Each
probe shows its env's point on the line its geometry predicts; image_u8 is round(255 x image).
"""
import math

import numpy as np

import cressim

from .test_ultrasound import MM, frame, point, probe

SECTOR = dict(kind="sector", scanlines=41, sector_angle=40.0, radius=0.0, lateral_beam_width=1.0 * MM, width=45,
              height=37)


def test_probes_of_different_sizes_fill_their_own_groups(make_engine):
    world = cressim.World(cressim.SceneLayout(2))
    places = {0: (1 * MM, 0, 6 * MM), 1: (-1 * MM, 0, 5 * MM)}
    for env, where in places.items():
        point(world, env, where)
        a = world.create_entity(env=env, name="linear")
        a.add(cressim.Transform())
        a.add(probe())
        b = world.create_entity(env=env, name="sector")
        b.add(cressim.Transform())
        b.add(probe(**SECTOR, rf_output=env == 1))  # RF only in env 1: a third group
    engine = make_engine(world)
    engine.prepare()
    engine.upload_world()
    probes = engine.ultrasound_probes
    assert probes["env"].tolist() == [0, 0, 1, 1]
    assert probes["group"].tolist() == [0, 1, 0, 2] and probes["layer"].tolist() == [0, 0, 1, 0]
    assert probes["lines"].tolist() == [96, 41, 96, 41] and probes["width"].tolist() == [96, 45, 96, 45]
    frame(engine)
    assert engine.buffer("ultrasound0.image").shape == (2, 128, 96)
    assert engine.buffer("ultrasound1.image").shape == (1, 37, 45)
    assert engine.buffer("ultrasound2.rf").shape[:2] == (1, 41)
    for env, group, layer in zip(probes["env"], probes["group"], probes["layer"]):
        iq = engine.buffer(f"ultrasound{group}.iq").read()[layer]
        line = np.hypot(iq[..., 0], iq[..., 1]).max(axis=1).argmax()
        x, _, z = places[env]
        if group == 0:  # linear: line u = (x - first line) / spacing
            assert line == round(x / (0.15 * MM) + 47.5)
        else:  # sector: 1 degree a line from -20
            assert abs(line - (math.degrees(math.atan2(x, z)) + 20)) <= 0.5
        image = engine.buffer(f"ultrasound{group}.image").read()[layer]
        assert image.max() > 0.5
        u8 = engine.buffer(f"ultrasound{group}.image_u8").read()[layer]
        assert u8.dtype == np.uint8 and u8.shape == image.shape
        assert np.array_equal(u8, np.round(image * 255).astype(np.uint8))
