"""`cressim demo ultrasound`: tissue boundaries in a B-mode image. A 7.5 MHz linear probe (128
lines over 51 mm, 60 mm deep, TGC for 0.5 dB/cm/MHz) looks into rigid tissues 60 mm wide:
- fat (1.38 MRayl, 0.6 dB/cm/MHz, weaker scatterers) from the face to 8 mm, coupled by gel of
  1.5 MRayl: an echo at the face and one at the fat/liver interface, r = (Z2 - Z1) / (Z2 + Z1);
- liver (1.65 MRayl, 0.5 dB/cm/MHz) below it, 150 scatterers per mm^3 (about 12 per resolution
  cell: fully developed speckle), with an anechoic cyst (5 mm radius) at 25 mm;
- a calcification (a 2.5 mm sphere of 7.8 MRayl, 10 dB/cm/MHz) at 25 mm: its front face echoes
  brightly, and behind it the lines keep (1 - R)^2 10^(-2 f0 alpha chord / 20) of their echoes,
  its acoustic shadow.
Saves <out>/ultrasound_boundaries.png (the image, uint8) and prints the echo of the fat/liver
interface and the shadow's loss on the central line against their formulas."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

import cressim
from cressim import io

MM = 1e-3
F0, DEPTH, SPACING, LINES = 7.5e6, 60 * MM, 0.4 * MM, 128
GEL, FAT, LIVER, BONE = 1.5, 1.38, 1.65, 7.8  # MRayl
CALCIFICATION = (10 * MM, 25 * MM, 2.5 * MM)  # x, depth, radius
HALF_ELEVATION = 2.6 * MM  # three elevational sigmas of the 2 mm beam


def tissue(world, name, depth, half, **fields):
    """A box of tissue centred `depth` below the probe's face."""
    t = world.create_entity(env=0, name=name)
    t.add(cressim.Transform(position=(0, 0, depth)))
    t.add(cressim.UltrasoundTissue(region="box", size=half, **fields))


def build() -> cressim.Engine:
    world = cressim.World(cressim.SceneLayout(1))
    tissue(world, "fat", 4 * MM, (30 * MM, HALF_ELEVATION, 4 * MM), density=150e9, amplitude_mean=0.5,
           amplitude_std=0.25, attenuation=0.6, impedance=FAT, seed=1)
    cyst = cressim.UltrasoundInclusion((-12 * MM, 0, -9 * MM), 5 * MM)
    tissue(world, "liver", 34 * MM, (30 * MM, HALF_ELEVATION, 26 * MM), density=150e9, attenuation=0.5,
           impedance=LIVER, inclusions=[cyst], seed=2)
    x, depth, radius = CALCIFICATION
    c = world.create_entity(env=0, name="calcification")
    c.add(cressim.Transform(position=(x, 0, depth)))
    c.add(cressim.UltrasoundTissue(region="sphere", size=(radius, 0, 0), density=150e9, amplitude_mean=2.0,
                                   attenuation=10.0, impedance=BONE, seed=3))
    p = world.create_entity(env=0, name="probe")
    p.add(cressim.Transform())
    p.add(cressim.UltrasoundProbe(kind="linear", scanlines=LINES, line_spacing=SPACING, line_length=DEPTH,
                                  width=256, height=300, center_frequency=F0, radial_decimation=4,
                                  lateral_beam_width=0.6 * MM, elevational_beam_width=2 * MM,
                                  time_gain_compensation=0.5 * F0 / 1e6 * 2, coupling_impedance=GEL,
                                  dynamic_range=55.0, gain=-30.0))
    engine = cressim.Engine(world)
    engine.prepare()
    engine.upload_world()
    return engine


def run(out_dir: str = "out/demo") -> int:
    engine = build()
    engine.step_simulation_sensors()
    engine.end_frame()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    path = io.save_png(out / "ultrasound_boundaries.png", engine.buffer("ultrasound0.image_u8").read()[0])
    iq = engine.buffer("ultrasound0.iq").read()[0]
    envelope = np.hypot(iq[..., 0], iq[..., 1])
    dz = 1540 / (2 * 40e6) * 4
    # the fat/liver interface at 8 mm on a line away from the cyst and the calcification
    line = LINES // 4
    r = (LIVER - FAT) / (LIVER + FAT)
    loss = 2 * F0 / 1e6 * (0.6 * 0.8)  # dB through 8 mm of fat, both ways
    transmitted = 1 - ((FAT - GEL) / (FAT + GEL)) ** 2
    expected = 1000 * r * transmitted * 10 ** (-loss / 20) * 10 ** (0.5 * F0 / 1e6 * 2 * 0.8 / 20)  # with the TGC
    k = int(8 * MM / dz)
    echo = envelope[line, k - 2:k + 3].max()
    print(f"fat/liver echo {echo:.1f} (formula {expected:.1f}: 1000 r (1 - R_face) 10^(-loss/20) x TGC, "
          f"r = {r:.4f}); {int(engine.ultrasound_probes['scatterers']):,} scatterers; wrote {path}")
    return 0
