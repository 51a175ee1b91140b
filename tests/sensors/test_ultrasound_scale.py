"""Ultrasound at scale: ten million scatterers under one probe in one env, more than one storage
binding holds on lavapipe (128 MiB: 8.4 M scatterers), so the projection runs in chunks.

Reference: the speckle's mean intensity is the incoherent sum E[a^2] rho pi^1.5 sigma_lat
sigma_elev sigma_z erf(h / sigma_elev) (test_ultrasound_speckle.py): a chunk left out would lose
its share of the scatterers (here 20 % or more of the intensity).
"""
import math

import numpy as np

import cressim

from .test_ultrasound_speckle import CELL, DZ, RAYLEIGH_LOG_STD, RAYLEIGH_SNR, SE, probe

COUNT = 10_500_000
HALF = (20e-3, 3.5 * SE, 6e-3)  # the slab's half extents: 40 x 3 x 12 mm


def test_ten_million_scatterers_under_one_probe(make_engine):
    world = cressim.World(cressim.SceneLayout(1))
    t = world.create_entity(env=0, name="slab")
    t.add(cressim.Transform(position=(0, 0, 7e-3)))
    t.add(cressim.UltrasoundTissue(region="box", size=HALF, count=COUNT, amplitude_mean=1.0, amplitude_std=0.5,
                                   attenuation=0.0))
    p = world.create_entity(env=0, name="probe")
    p.add(cressim.Transform())
    p.add(probe("linear"))
    engine = make_engine(world)
    engine.prepare()
    engine.upload_world()
    assert int(engine.ultrasound_probes["scatterers"]) == COUNT
    per_binding = engine.device["max_storage_buffer_range"] // 16
    chunks = -(-COUNT // per_binding)
    sizes = [engine.buffer("ultrasound.scatterers" + (f".{k}" if k else "")).shape[0] for k in range(chunks)]
    assert sum(sizes) == COUNT
    engine.step_simulation_sensors()
    engine.end_frame()
    iq = engine.buffer("ultrasound0.iq").read().astype(np.float64)
    intensity = (iq[..., 0] ** 2 + iq[..., 1] ** 2)[0, 8:40, int(2.5e-3 / DZ):int(11.5e-3 / DZ)]
    envelope = np.sqrt(intensity)
    density = COUNT / (8 * HALF[0] * HALF[1] * HALF[2])
    expected = (1.0 + 0.5 ** 2) * density * CELL * math.erf(3.5)
    snr, log_std = envelope.mean() / envelope.std(), (20 * np.log10(envelope)).std()
    print(f"{COUNT:,} scatterers in {chunks} chunk(s) ({density * CELL:.0f} per resolution cell): SNR {snr:.3f}, "
          f"log std {log_std:.2f} dB, mean intensity {intensity.mean() / expected:.3f} of the incoherent sum")
    assert abs(intensity.mean() / expected - 1) <= 0.1
    assert abs(snr - RAYLEIGH_SNR) <= 0.1 and abs(log_std - RAYLEIGH_LOG_STD) <= 0.5
