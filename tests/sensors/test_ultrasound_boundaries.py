"""Tissue boundaries along the scanlines: attenuation accumulated through the tissues a line
crosses, specular echoes at interfaces, and the acoustic shadow behind a calcification.

References: a tissue of attenuation alpha (dB/cm/MHz) and thickness L takes 2 alpha f0 L dB off
an echo from behind it (both ways); at an interface between impedances Z1 and Z2 the pressure
reflection coefficient is r = (Z2 - Z1) / (Z2 + Z1), the intensity reflection coefficient R =
r^2, and the echoes from behind it keep (1 - R) of their amplitude (transmission there and back,
t12 t21 = 4 Z1 Z2 / (Z1 + Z2)^2 = 1 - R).
"""
import math

import numpy as np
import pytest

import cressim

from .test_ultrasound import FS, MM, C, F0, point, probe, sensed_iq

SPECULAR = 1000.0  # the probe's plane-reflector echo, in scatterer amplitudes
DZ = C / (2 * FS) * 4
K2 = 2 * 2 * math.pi * F0 / C  # two-way wavenumber


def line_x(line):
    return (line - 47.5) * 0.15 * MM  # the test probe's scanline positions


def slab(world, env, name, z0, z1, x0=-8 * MM, x1=8 * MM, attenuation=0.0, impedance=1.63):
    """A box medium between depths z0 and z1 and laterally x0..x1, without scatterers of its own."""
    t = world.create_entity(env=env, name=name)
    t.add(cressim.Transform(position=((x0 + x1) / 2, 0, (z0 + z1) / 2)))
    t.add(cressim.UltrasoundTissue(region="box", size=((x1 - x0) / 2, 2 * MM, (z1 - z0) / 2), count=1,
                                   amplitude_mean=0.0, amplitude_std=0.0, attenuation=attenuation,
                                   impedance=impedance))
    return t


def imaged(make_engine, world, **fields):
    p = world.create_entity(env=0, name="probe")
    p.add(cressim.Transform())
    p.add(probe(specular_amplitude=SPECULAR, **fields))
    return sensed_iq(make_engine, world)[0]


@pytest.mark.parametrize("kind", ["linear", "sector"])
def test_attenuation_accumulates_through_the_tissues_a_line_crosses(make_engine, kind):
    """Two points 6 mm along lines 8.2 degrees (sector; linear: 2.9 mm) either side of the axis,
    one under two lossy layers (3 and 1.5 dB/cm/MHz, 2 mm each), one beside them: the first's
    echo is 2 f0 (3 x 0.2 + 1.5 x 0.2) = 9 dB weaker, over cos(angle) on the sector's slanted line."""
    world = cressim.World(cressim.SceneLayout(1))
    left, right, radius = 28, 67, 10 * MM
    angle = math.radians(-20 + right * 40 / 95)  # the sector probe's line 67
    for line in (left, right):
        if kind == "linear":
            point(world, 0, (line_x(line), 0, 6 * MM))
        else:
            a = math.radians(-20 + line * 40 / 95)
            point(world, 0, ((radius + 6 * MM) * math.sin(a), 0, (radius + 6 * MM) * math.cos(a) - radius))
    slab(world, 0, "upper", 1 * MM, 3 * MM, x0=0.5 * MM, attenuation=3.0)
    slab(world, 0, "lower", 3 * MM, 5 * MM, x0=0.5 * MM, attenuation=1.5)
    iq = imaged(make_engine, world, **({} if kind == "linear" else dict(kind="sector", sector_angle=40.0,
                                                                          radius=radius)))
    loss = 20 * math.log10(np.abs(iq[left]).max() / np.abs(iq[right]).max())
    expected = 2 * F0 / 1e6 * (3.0 * 0.2 + 1.5 * 0.2) / (1 if kind == "linear" else math.cos(angle))
    print(f"{kind}: two-way loss through the layers {loss:.3f} dB (formula {expected:.3f})")
    assert abs(loss - expected) < 0.02
    assert not np.abs(iq).max() > 1.01  # equal impedances: no echoes from the layers


def test_media_follow_their_region_and_pose(make_engine):
    """A point at 8 mm on the central line under a lossy (3 dB/cm/MHz) cylinder along the beam
    (1 mm half height: 2 f0 alpha 0.2 cm = 6 dB) and under a 2 mm slab tilted 30 degrees about
    the elevation (6 / cos 30 = 6.928 dB), against the same point with nothing above it."""
    def medium(world, env):
        if env == 0:
            t = world.create_entity(env=env, name="cylinder")
            t.add(cressim.Transform(position=(0, 0, 3 * MM)))
            t.add(cressim.UltrasoundTissue(region="cylinder", size=(2 * MM, 1 * MM, 0), count=1, amplitude_mean=0.0,
                                           amplitude_std=0.0, attenuation=3.0))
        elif env == 1:
            t = world.create_entity(env=env, name="tilted")
            half = math.radians(30) / 2
            t.add(cressim.Transform(position=(0, 0, 3 * MM), rotation=(0, math.sin(half), 0, math.cos(half))))
            t.add(cressim.UltrasoundTissue(region="box", size=(4 * MM, 2 * MM, 1 * MM), count=1, amplitude_mean=0.0,
                                           amplitude_std=0.0, attenuation=3.0))

    world = cressim.World(cressim.SceneLayout(3))
    for env in range(3):
        point(world, env, (line_x(48), 0, 8 * MM))
        medium(world, env)
        p = world.create_entity(env=env, name="probe")
        p.add(cressim.Transform())
        p.add(probe())
    peak = np.abs(sensed_iq(make_engine, world)[:, 48]).max(axis=1)
    losses = 20 * np.log10(peak[2] / peak[:2])
    expected = [2 * F0 / 1e6 * 3.0 * 0.2, 2 * F0 / 1e6 * 3.0 * 0.2 / math.cos(math.radians(30))]
    print(f"cylinder {losses[0]:.3f} dB (formula {expected[0]:.3f}), tilted slab {losses[1]:.3f} dB "
          f"(formula {expected[1]:.3f})")
    np.testing.assert_allclose(losses, expected, atol=0.02)


def test_interface_echoes_match_the_reflection_coefficient(make_engine):
    """Fat (1.38 MRayl) from 2 to 5 mm, muscle (1.70 MRayl, 1 dB/cm/MHz) from 5 to 9 mm, in a
    fat-matched coupling medium: echoes of r = 0.104 at 5 mm and -r (1 - R) less 4 dB of loss at 9 mm."""
    z_fat, z_muscle = 1.38, 1.70
    world = cressim.World(cressim.SceneLayout(1))
    slab(world, 0, "fat", 2 * MM, 5 * MM, impedance=z_fat)
    slab(world, 0, "muscle", 5 * MM, 9 * MM, impedance=z_muscle, attenuation=1.0)
    iq = imaged(make_engine, world, coupling_impedance=z_fat)
    r = (z_muscle - z_fat) / (z_muscle + z_fat)
    expected = {5 * MM: SPECULAR * r, 9 * MM: -SPECULAR * r * (1 - r * r) * 10 ** (-2 * F0 / 1e6 * 1.0 * 0.4 / 20)}
    line = iq[48]
    for depth, echo in expected.items():
        k = int(depth / DZ)  # the sample whose bin holds the interface
        assert np.abs(line[k]) == np.abs(line[k - 3:k + 4]).max()
        model = echo * np.exp(-1j * K2 * depth)
        reflection = (abs(line[k]) / SPECULAR) ** 2
        print(f"echo at {depth / MM:.0f} mm: {line[k]:.3f} (formula {model:.3f}), intensity reflection "
              f"{reflection:.6f}")
        assert abs(line[k] - model) < 1e-3 * abs(model)
    assert abs((abs(line[int(5 * MM / DZ)]) / SPECULAR) ** 2 - r * r) < 1e-5
    assert np.abs(line[:int(5 * MM / DZ) - 6]).max() < 1e-6  # fat against fat-matched coupling: no echo
    np.testing.assert_allclose(np.abs(iq[0]), np.abs(iq[95]), rtol=1e-4)  # a plane: every line alike


def test_a_calcification_casts_its_shadow(make_engine):
    """A sphere of bone (7.8 MRayl, 5 dB/cm/MHz, radius 1.5 mm) in speckle: behind it each line's
    echoes keep (1 - R)^2 10^(-2 f0 alpha chord / 20) of what the same speckle gives without it
    (the same scatterers: the phantom is the same entity with the same seed), beside it all."""
    radius, centre, alpha, z_bone = 1.5 * MM, 5 * MM, 5.0, 7.8

    def speckle(with_bone):
        world = cressim.World(cressim.SceneLayout(1))
        t = world.create_entity(env=0, name="phantom")
        t.add(cressim.Transform(position=(0, 0, 6 * MM)))
        t.add(cressim.UltrasoundTissue(region="box", size=(8 * MM, 1.6 * MM, 6 * MM), density=200e9,
                                       attenuation=0.0))
        if with_bone:
            b = world.create_entity(env=0, name="calcification")
            b.add(cressim.Transform(position=(0, 0, centre)))
            b.add(cressim.UltrasoundTissue(region="sphere", size=(radius, 0, 0), count=1, amplitude_mean=0.0,
                                           amplitude_std=0.0, attenuation=alpha, impedance=z_bone))
        return imaged(make_engine, world)

    shadowed, clear = speckle(True), speckle(False)
    R = ((z_bone - 1.63) / (z_bone + 1.63)) ** 2
    behind = slice(int((centre + radius + 0.6 * MM) / DZ), int(11 * MM / DZ))
    for line in (44, 46, 47, 48, 50, 52, 53, 60):
        x = line_x(line)
        chord = 2 * math.sqrt(max(radius ** 2 - x ** 2, 0))
        factor = (1 - R) ** 2 * 10 ** (-2 * F0 / 1e6 * alpha * chord * 100 / 20) if chord else 1.0
        ratio = np.abs(shadowed[line, behind]).sum() / np.abs(clear[line, behind]).sum()
        print(f"line at {x / MM:+.3f} mm: chord {chord / MM:.3f} mm, shadow {20 * math.log10(ratio):.2f} dB "
              f"(formula {20 * math.log10(factor):.2f})")
        assert abs(ratio / factor - 1) < 0.01
    # the bone's front face echoes r = (Z2 - Z1) / (Z2 + Z1) of the plane reflector on the central lines
    front = np.abs(shadowed[47, int((centre - radius) / DZ) - 2:int((centre - radius) / DZ) + 3]).max()
    r = (z_bone - 1.63) / (z_bone + 1.63)
    assert abs(front / (SPECULAR * r) - 1) < 0.05


def test_bad_acoustics_name_the_entity_and_field(make_engine):
    for fields, message in (({"impedance": 0.0}, "'slab' in env 0: UltrasoundTissue.impedance must be positive"),
                            ({"impedance": math.nan}, "'slab' in env 0: UltrasoundTissue.impedance must be positive")):
        world = cressim.World(cressim.SceneLayout(1))
        world.create_entity(env=0, name="slab").add(
            cressim.UltrasoundTissue(size=(0.01, 0.01, 0.01), count=1, **fields))
        with pytest.raises(ValueError, match=message):
            make_engine(world).prepare()
    for fields, message in (({"coupling_impedance": -1.0}, "UltrasoundProbe.coupling_impedance must be positive"),
                            ({"specular_amplitude": math.inf}, "UltrasoundProbe.specular_amplitude must be")):
        world = cressim.World(cressim.SceneLayout(2))
        world.create_entity(env=1, name="probe").add(probe(**fields))
        with pytest.raises(ValueError, match="'probe' in env 1: " + message):
            make_engine(world).prepare()


def test_the_demo_shows_its_cyst_shadow_and_interface(tmp_path):
    """cressim demo ultrasound (fat over liver, a cyst, a calcification): dark where the cyst and
    the calcification's shadow are, a bright row at the fat/liver interface, speckle elsewhere."""
    from cressim.demos import ultrasound as demo

    assert demo.run(str(tmp_path)) == 0
    engine = demo.build()
    engine.step_simulation_sensors()
    engine.end_frame()
    image = engine.buffer("ultrasound0.image_u8").read()[0].astype(float) / 255  # 300 x 256 over 60 x 51.2 mm

    def row(depth):
        return int(depth / (demo.DEPTH / 300))

    def col(x):
        return int((x + 64 * demo.SPACING) / (128 * demo.SPACING / 256))

    x, depth, radius = demo.CALCIFICATION
    shadow = image[row(depth + radius + 3 * MM):row(55 * MM), col(x - 0.5 * MM):col(x + 0.5 * MM)]
    beside = image[row(depth + radius + 3 * MM):row(55 * MM), col(x + 5 * MM):col(x + 15 * MM)]
    cyst = image[row(24 * MM):row(26 * MM), col(-13 * MM):col(-11 * MM)]
    interface = image[row(8 * MM) - 1:row(8 * MM) + 2, col(-20 * MM):col(0)].max(axis=0)
    print(f"shadow {shadow.mean():.3f}, beside {beside.mean():.3f}, cyst {cyst.mean():.3f}, interface "
          f"{interface.mean():.3f}")
    assert shadow.mean() < 0.05 and cyst.mean() < 0.05 and beside.mean() > 0.4
    assert interface.min() > 0.95  # the interface echo saturates every column's row
    assert (tmp_path / "ultrasound_boundaries.png").exists()
    assert engine.validation_enabled and engine.validation_messages == []
