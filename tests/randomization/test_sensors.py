"""Sensor randomization: a camera's depth noise has the drawn standard deviation (zero mean, new
every frame) in its own env only; an ultrasound probe's drawn gain (dB) scales each env's
displayed envelope by 10^(gain / 20): a log-compressed pixel moves by gain / dynamic range."""

import numpy as np

import cressim
from cressim.randomization import Randomizer

from .frames import randomized_frame

MM = 1e-3

DOWN = (1.0, 0.0, 0.0, 0.0)  # the camera's +z (its view) turned to the world's -z


def depth_world(envs):
    """Per env a 64 x 64 depth camera 1 m above a wide slab (top at z = 0); env 1's camera has
    another name, so a term for "camera" leaves it alone."""
    world = cressim.World(cressim.SceneLayout(envs))
    slab = world.add_mesh(cressim.Mesh.box((3.0, 3.0, 0.05)))
    for env in range(envs):
        ground = world.create_entity(env=env, name="ground")
        ground.add(cressim.Transform(position=(0, 0, -0.05)))
        ground.add(cressim.Renderable(slab))
        cam = world.create_entity(env=env, name="camera" if env != 1 else "other_camera")
        cam.add(cressim.Transform(position=(0, 0, 1.0), rotation=DOWN))
        cam.add(cressim.Camera(width=64, height=64, fov_y=50.0, products=["depth"]))
    return world


def test_depth_noise_has_the_drawn_std_in_its_own_env_and_changes_every_frame(make_engine):
    engine = make_engine(depth_world(3))
    engine.prepare()
    engine.upload_world()
    engine.step_visual_sensors()
    engine.end_frame()
    clean = engine.buffer("camera0.depth").read().copy()  # (layers, H, W)
    assert np.allclose(clean, 1.0, atol=1e-4)  # the slab is everywhere 1 m away
    r = Randomizer(engine, [dict(param="depth_noise", entity="camera", range=[0.002, 0.02], operation="abs")], seed=7)
    layer = {int(e): int(l) for e, l in zip(engine.cameras["env"], engine.cameras["layer"])}
    randomized_frame(engine, r, reset_all=True, physics=False, sensors=["step_visual_sensors"])
    noisy = engine.buffer("camera0.depth").read().copy()
    randomized_frame(engine, r, physics=False, sensors=["step_visual_sensors"])
    again = engine.buffer("camera0.depth").read().copy()
    sigma = r.read("depth_noise/camera")[:, 0]
    for env in (0, 2):
        d = (noisy - clean)[layer[env]]
        assert abs(d.std() / sigma[env] - 1) < 0.05, (env, d.std(), sigma[env])  # 4096 pixels: 1 % std error
        assert abs(d.mean()) < 4 * sigma[env] / 64
        assert not np.array_equal(noisy[layer[env]], again[layer[env]])  # drawn anew each frame
        # gaussian: 68 % within one std
        assert abs(np.mean(np.abs(d) < sigma[env]) - 0.6827) < 0.03
    np.testing.assert_array_equal(noisy[layer[1]], clean[layer[1]])  # env 1's camera is not randomized
    assert abs(sigma[0] - sigma[2]) > 1e-4


def test_ultrasound_gain_scales_each_envs_envelope_by_its_drawn_decibels(make_engine):
    world = cressim.World(cressim.SceneLayout(2))
    for env in range(2):  # speckle in a box 12 x 3 x 10 mm under a small 5 MHz linear probe
        t = world.create_entity(env=env, name="phantom")
        t.add(cressim.Transform(position=(0, 0, 6.5 * MM)))
        t.add(cressim.UltrasoundTissue(region="box", size=(6 * MM, 1.6 * MM, 5 * MM), density=500e9))
        p = world.create_entity(env=env, name="probe")
        p.add(cressim.Transform())
        p.add(cressim.UltrasoundProbe(kind="linear", scanlines=48, line_spacing=0.2 * MM, line_length=12 * MM,
                                      width=48, height=64, center_frequency=5e6, dynamic_range=60.0, gain=-45.0))
    engine = make_engine(world)
    engine.prepare()
    engine.upload_world()
    engine.step_simulation_sensors()
    engine.end_frame()
    before = engine.buffer("ultrasound0.image").read().copy()
    r = Randomizer(engine, [dict(param="ultrasound_gain", entity="probe", range=[-12.0, 12.0], operation="add")],
                   seed=4)
    randomized_frame(engine, r, reset_all=True, physics=False, sensors=["step_simulation_sensors"])
    after = engine.buffer("ultrasound0.image").read().copy()
    gain = r.read("ultrasound_gain/probe")[:, 0]
    assert abs(gain[0] - gain[1]) > 0.5  # each env's ratio below tells its own gain from the other's
    dynamic_range = 60.0
    for env in range(2):
        inside = (before[env] > 0.02) & (before[env] < 0.98) & (after[env] > 0.02) & (after[env] < 0.98)
        assert inside.sum() > 500
        # displayed envelope ratio 10^((after - before) DR / 20) = 10^(gain / 20)
        ratio = 10 ** ((after[env][inside] - before[env][inside]) * dynamic_range / 20)
        np.testing.assert_allclose(ratio, 10 ** (gain[env] / 20), rtol=1e-3)
    probes = engine.buffer("ultrasound0.probes").read().view(np.float32).reshape(2, -1)
    np.testing.assert_allclose(probes[:, 21], -45.0 + gain, rtol=1e-6)
