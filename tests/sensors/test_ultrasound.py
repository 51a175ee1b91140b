"""The ultrasound sensor (COLE B-mode) checked against speckle statistics, the point-spread
function's theory, geometry, contrast, motion, env isolation and bad input.

References: fully developed speckle has a Rayleigh envelope, mean/std = sqrt(pi / (4 - pi)) =
1.91, and its log-compressed std is 5.57 dB (Wagner et al. 1983; Burckhardt 1978). A point's
envelope is the pulse envelope axially (FWHM 2 sqrt(2 ln 2) sigma_z, sigma_z = c sigma_t / 2,
sigma_t = 1 / (2 pi sigma_f), sigma_f = B f0 / (2 sqrt(2 ln 2))) and the beam profile laterally.
"""
import math

import numpy as np
import pytest

import cressim

FWHM = 2 * math.sqrt(2 * math.log(2))
C, F0, B, FS = 1540.0, 5e6, 0.5, 40e6
MM = 1e-3


def probe(**over):
    """A small linear probe in metres: 5 MHz, 0.6 mm lateral and 1 mm elevational beam."""
    kw = dict(kind="linear", scanlines=96, line_spacing=0.15 * MM, line_length=12 * MM, width=96, height=128,
              sampling_frequency=FS, radial_decimation=4, center_frequency=F0, fractional_bandwidth=B,
              lateral_beam_width=0.6 * MM, elevational_beam_width=1.0 * MM, speed_of_sound=C, dynamic_range=60.0,
              gain=0.0)
    kw.update(over)
    return cressim.UltrasoundProbe(**kw)


def sigma_z():
    return C / (2 * (2 * math.pi * B * F0 / FWHM))


def build(make_engine, envs, tissues, probe_kwargs=None):
    """tissues(world, env) adds an env's tissue entities; every env gets the probe at the origin."""
    world = cressim.World(cressim.SceneLayout(envs))
    for env in range(envs):
        tissues(world, env)
        p = world.create_entity(env=env, name="probe")
        p.add(cressim.Transform())
        p.add(probe(**(probe_kwargs or {})))
    engine = make_engine(world)
    engine.prepare()
    engine.upload_world()
    return engine, world


def sensed_iq(make_engine, world) -> np.ndarray:
    """One frame of `world`'s probes: their IQ as complex numbers (probes, lines, samples), float64."""
    engine = make_engine(world)
    engine.prepare()
    engine.upload_world()
    engine.step_simulation_sensors()
    engine.end_frame()
    iq = engine.buffer("ultrasound0.iq").read().astype(np.float64)
    return iq[..., 0] + 1j * iq[..., 1]


def frame(engine):
    engine.step_simulation_sensors()
    engine.end_frame()
    iq = engine.buffer("ultrasound0.iq").read()
    return np.hypot(iq[..., 0], iq[..., 1]), engine.buffer("ultrasound0.image").read()


def phantom(world, env, density=500e9, position=(0, 0, 6.5 * MM), attenuation=0.0, **tissue):
    """A box of speckle 8 x 1.6 x 6.5 mm (half extents); no attenuation unless asked for."""
    t = world.create_entity(env=env, name="phantom")
    t.add(cressim.Transform(position=position))
    t.add(cressim.UltrasoundTissue(region="box", size=(8 * MM, 1.6 * MM, 6.5 * MM), density=density,
                                   attenuation=attenuation, **tissue))
    return t


def point(world, env, position, amplitude=1.0, attenuation=0.0):
    t = world.create_entity(env=env, name="point")
    t.add(cressim.Transform(position=position))
    t.add(cressim.UltrasoundTissue(region="sphere", size=(1e-9, 0, 0), count=1, amplitude_mean=amplitude,
                                   amplitude_std=0.0, attenuation=attenuation))
    return t


def half_max_width(profile, step):
    """FWHM of a single peak, half-maximum crossings interpolated linearly."""
    k = int(np.argmax(profile))
    half = profile[k] / 2
    lo = k
    while profile[lo - 1] > half:
        lo -= 1
    hi = k
    while profile[hi + 1] > half:
        hi += 1
    left = lo - 1 + (half - profile[lo - 1]) / (profile[lo] - profile[lo - 1])
    right = hi + (profile[hi] - half) / (profile[hi] - profile[hi + 1])
    return (right - left) * step


def test_fully_developed_speckle_statistics(make_engine):
    engine, _ = build(make_engine, 1, lambda w, env: phantom(w, env))
    env, _ = frame(engine)
    dz = C / (2 * FS) * 4
    region = env[0, 12:84, int(2 * MM / dz):int(10 * MM / dz)]  # away from the phantom's edges
    snr = region.mean() / region.std()
    log_std = (20 * np.log10(region)).std()
    print(f"speckle: SNR {snr:.3f} (1.91 +- 0.15), log std {log_std:.2f} dB (5.57)")
    assert abs(snr - 1.91) <= 0.15
    assert abs(log_std - 5.57) <= 0.5


def test_point_spread_matches_pulse_and_beam(make_engine):
    depth_px = 0.09375 * MM  # 12 mm over 128 rows
    depth = 53.5 * depth_px
    engine, _ = build(make_engine, 1, lambda w, env: point(w, env, (0.0, 0.0, depth)), {"radial_decimation": 2})
    env, image = frame(engine)
    dz = C / (2 * FS) * 2
    line, sample = np.unravel_index(np.argmax(env[0]), env[0].shape)
    axial = half_max_width(env[0, line, :], dz)
    lateral = half_max_width(env[0, :, sample], 0.15 * MM)
    print(f"point: axial FWHM {axial / MM:.4f} mm (theory {FWHM * sigma_z() / MM:.4f}), lateral "
          f"{lateral / MM:.4f} mm (0.6)")
    assert abs(axial / (FWHM * sigma_z()) - 1) < 0.10
    assert abs(lateral / (0.6 * MM) - 1) < 0.10
    # the point shows at its depth's row, in the middle column pair
    row, col = np.unravel_index(np.argmax(image[0]), image[0].shape)
    assert row == 53 and col in (47, 48)


def test_rf_on_request_oscillates_at_the_centre_frequency(make_engine):
    engine, _ = build(make_engine, 1, lambda w, env: point(w, env, (0.0, 0.0, 5 * MM)), {"rf_output": True})
    env, _ = frame(engine)
    rf = engine.buffer("ultrasound0.rf").read()
    assert rf.shape == (1, 96, env.shape[2] * 4)  # the full sampling rate
    line = np.argmax(env[0].max(axis=1))
    spectrum = np.abs(np.fft.rfft(rf[0, line]))
    peak = np.fft.rfftfreq(rf.shape[2], 1 / FS)[np.argmax(spectrum)]
    print(f"RF peak frequency {peak / 1e6:.3f} MHz (5)")
    assert abs(peak / F0 - 1) < 0.05
    assert abs(np.abs(rf[0, line]).max() / env[0, line].max() - 1) < 0.05  # carrier under the same envelope
    with pytest.raises(cressim.BindingError, match="unknown buffer key 'ultrasound0.rf'"):
        build(make_engine, 1, lambda w, env: None)[0].buffer("ultrasound0.rf")


def test_anechoic_cyst_is_dark_and_moves_with_the_tissue(make_engine):
    cyst = cressim.UltrasoundInclusion((0, 0, 0), 2.5 * MM, amplitude_scale=0.0)
    engine, world = build(make_engine, 1, lambda w, env: phantom(w, env, density=200e9, inclusions=[cyst]))
    env, image = frame(engine)
    dz = C / (2 * FS) * 4
    lines = (np.arange(96) - 47.5) * 0.15 * MM
    depths = (np.arange(env.shape[2]) + 0.5) * dz
    r = np.hypot(lines[:, None], depths[None, :] - 6.5 * MM)
    inside, outside = env[0][r < 1.0 * MM] ** 2, env[0][(r > 3.5 * MM) & (np.abs(lines[:, None]) < 6 * MM)] ** 2
    contrast = 10 * np.log10(inside.mean() / outside.mean() + 1e-30)
    print(f"cyst contrast {contrast:.1f} dB")
    assert contrast <= -20

    def dark_centre(img):  # centroid of the dark pixels inside the phantom's depth range
        rows, cols = np.nonzero(img[10:118] < 0.1)
        return cols.mean(), rows.mean() + 10

    before = dark_centre(image[0])
    tissue = next(world.entity(e) for e in range(world.entity_count) if world.entity(e).name == "phantom")
    tissue.transform = cressim.Transform(position=(1.5 * MM, 0, 6.5 * MM))
    _, moved = frame(engine)
    after = dark_centre(moved[0])
    px = 96 * 0.15 * MM / 96
    assert abs((after[0] - before[0]) - 1.5 * MM / px) < 1.0 and abs(after[1] - before[1]) < 1.0


def test_envs_see_only_their_own_tissue_and_are_deterministic(make_engine):
    engine, _ = build(make_engine, 3, lambda w, env: env != 1 and phantom(w, env, density=50e9))
    env, image = frame(engine)
    assert engine.ultrasound_probes["env"].tolist() == [0, 1, 2]
    assert env[1].max() == 0 and image[1].max() == 0
    assert env[0].max() > 0 and env[2].max() > 0
    assert not np.array_equal(env[0], env[2])  # each env's tissue has its own speckle
    again, _ = frame(engine)
    assert np.array_equal(env, again)  # integer accumulation: bit-identical frames


def test_sector_probe_places_a_point_by_range_and_angle(make_engine):
    angle, rng, radius = math.radians(12), 20 * MM, 10 * MM
    # the apex sits `radius` behind the face; a point `rng` beyond the face along a 12 degree line
    x, z = (radius + rng) * math.sin(angle), (radius + rng) * math.cos(angle) - radius
    sector = dict(kind="sector", scanlines=121, sector_angle=60.0, radius=radius, line_length=30 * MM, width=128,
                  height=128, lateral_beam_width=1.0 * MM)
    engine, _ = build(make_engine, 1, lambda w, env: point(w, env, (x, 0, z)), sector)
    env, image = frame(engine)
    line, _ = np.unravel_index(np.argmax(env[0]), env[0].shape)
    assert line == 60 + 24  # 0.5 degrees per line
    half = (radius + 30 * MM) * math.sin(math.radians(30))
    top = radius * math.cos(math.radians(30)) - radius
    row, col = np.unravel_index(np.argmax(image[0]), image[0].shape)
    assert abs(col - ((x + half) / (2 * half / 128) - 0.5)) <= 1.0
    assert abs(row - ((z - top) / ((30 * MM - top) / 128) - 0.5)) <= 1.0


def test_every_probe_of_an_env_fills_its_own_layer(make_engine):
    """A linear and a sector probe in env 0 and a linear one in env 1, one point in each env: each
    probe's layer shows its env's point where that probe's geometry puts it."""
    world = cressim.World(cressim.SceneLayout(2))
    sector = dict(kind="sector", sector_angle=40.0, radius=0.0, lateral_beam_width=1.0 * MM)
    for env, where in ((0, (1 * MM, 0, 6 * MM)), (1, (-2 * MM, 0, 4 * MM))):
        point(world, env, where)
        a = world.create_entity(env=env, name="linear")
        a.add(cressim.Transform())
        a.add(probe())
        if env == 0:
            b = world.create_entity(env=env, name="sector")
            b.add(cressim.Transform(position=(-1 * MM, 0, 0)))
            b.add(probe(**sector))
    engine = make_engine(world)
    engine.prepare()
    engine.upload_world()
    probes = engine.ultrasound_probes
    assert probes["env"].tolist() == [0, 0, 1] and probes["layer"].tolist() == [0, 1, 2]
    names = [world.entity(int(e)).name for e in probes["entity"]]
    assert names == ["linear", "sector", "linear"]
    env, image = frame(engine)
    assert image.shape == (3, 128, 96)
    lines = env.max(axis=2).argmax(axis=1)
    # linear: line u = (x - first line) / spacing; sector: angle from the apex, 40/95 degrees a line
    assert lines[0] == round(1 * MM / (0.15 * MM) + 47.5)
    assert lines[2] == round(-2 * MM / (0.15 * MM) + 47.5)
    angle = math.degrees(math.atan2(2 * MM, 6 * MM))
    assert abs(lines[1] - (angle + 20) / (40 / 95)) <= 0.5
    for layer in range(3):  # every layer shows something, and only its own env's point
        assert image[layer].max() > 0.5
    assert not np.array_equal(image[0], image[2])


def test_bad_input_names_the_entity_and_field(make_engine):
    with pytest.raises(TypeError, match="UltrasoundProbe\\(\\) has no field 'scan_lines'"):
        cressim.UltrasoundProbe(scan_lines=4)
    with pytest.raises(ValueError, match="UltrasoundProbe kind 'convex' is not one of: linear, sector"):
        cressim.UltrasoundProbe(kind="convex")
    world = cressim.World(cressim.SceneLayout(2))
    p = world.create_entity(env=1, name="probe")
    p.add(probe(line_spacing=0.0))
    with pytest.raises(ValueError, match="'probe' in env 1: UltrasoundProbe.line_spacing must be positive"):
        make_engine(world).prepare()
    world = cressim.World(cressim.SceneLayout(1))
    world.create_entity(env=0, name="liver").add(cressim.UltrasoundTissue(size=(0.01, 0.01, 0.01)))
    with pytest.raises(ValueError, match="'liver' in env 0: UltrasoundTissue: give either density or count"):
        make_engine(world).prepare()


def test_png_export(make_engine, tmp_path):
    from cressim.sensors import save_ultrasound_png

    engine, _ = build(make_engine, 2, lambda w, env: phantom(w, env, density=20e9), {"scanlines": 32, "width": 40})
    frame(engine)
    paths = save_ultrasound_png(engine, tmp_path)
    assert [p.name for p in paths] == ["ultrasound_env0_layer0.png", "ultrasound_env1_layer1.png"]
    data = paths[0].read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and int.from_bytes(data[16:20], "big") == 40  # width in IHDR
