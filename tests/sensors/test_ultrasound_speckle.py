"""Speckle statistics of the ultrasound sensor at any scatterer density and phantom thickness,
for linear and sector probes.

References: fully developed speckle (about 10 or more scatterers per resolution cell) is a
circular complex Gaussian sum: its envelope is Rayleigh, mean/std = sqrt(pi / (4 - pi)) = 1.91,
and its log-compressed std is 5.57 dB (Wagner et al. 1983), however dense the scatterers. Its
mean intensity is the incoherent sum of the scatterers' weights squared: E|IQ|^2 = E[a^2] rho
integral(w^2) over the tissue, with the two-way Gaussian beam and pulse weights w that gives
E[a^2] rho pi^1.5 sigma_lat sigma_elev sigma_z erf(h / sigma_elev) for a slab of half
thickness h (E[a^2] = mean^2 + std^2 of the amplitudes).

The IQ samples are 6x decimated RF: with the scatterers' envelopes on that grid the carrier
aliased, and the speckle turned Rician as the density grew (SNR 3.3 at 100 scatterers per
cell, 10.7 at 1,000).
"""
import math

import numpy as np
import pytest

import cressim

from .test_ultrasound import FS, FWHM, MM, B, C, F0, sensed_iq, sigma_z

RAYLEIGH_SNR, RAYLEIGH_LOG_STD = math.sqrt(math.pi / (4 - math.pi)), 5.57
SL, SE = 0.6 * MM / FWHM, 1.0 * MM / FWHM  # two-way beam sigmas of the probe below
CELL = math.pi ** 1.5 * SL * SE * sigma_z()  # resolution cell volume
DECIMATION = 6
DZ = C / (2 * FS) * DECIMATION
# per resolution cell, slab half thickness in elevational sigmas (2.5: as good as infinite)
SWEEP = [(10, 2.5), (100, 2.5), (1000, 2.5), (100, 0.5), (1000, 0.5)]
AMPLITUDE_MEAN, AMPLITUDE_STD = 1.0, 0.5
GEOMETRY = {  # 14 x 12 mm of speckle; lines 0.3 mm apart (sector: at mid depth)
    "linear": dict(kind="linear", scanlines=48, line_spacing=0.3 * MM),
    "sector": dict(kind="sector", scanlines=48, sector_angle=26.0, radius=25 * MM),
}


def probe(kind):
    return cressim.UltrasoundProbe(**GEOMETRY[kind], line_length=15 * MM, width=48, height=64,
                                   sampling_frequency=FS, radial_decimation=DECIMATION, center_frequency=F0,
                                   fractional_bandwidth=B, lateral_beam_width=0.6 * MM,
                                   elevational_beam_width=1.0 * MM, speed_of_sound=C, dynamic_range=60.0, gain=0.0)


@pytest.mark.parametrize("kind", ["linear", "sector"])
def test_speckle_is_rayleigh_at_any_density_and_thickness(make_engine, kind):
    world = cressim.World(cressim.SceneLayout(len(SWEEP)))
    for env, (per_cell, half) in enumerate(SWEEP):
        t = world.create_entity(env=env, name="phantom")
        t.add(cressim.Transform(position=(0, 0, 8 * MM)))
        t.add(cressim.UltrasoundTissue(region="box", size=(7.5 * MM, half * SE, 7 * MM), density=per_cell / CELL,
                                       amplitude_mean=AMPLITUDE_MEAN, amplitude_std=AMPLITUDE_STD, attenuation=0.0))
        p = world.create_entity(env=env, name="probe")
        p.add(cressim.Transform())
        p.add(probe(kind))
    intensity = np.abs(sensed_iq(make_engine, world)) ** 2
    # away from the slab's edges by more than the beam's and pulse's reach
    rows = slice(8, 40)
    samples = slice(int(2.5 * MM / DZ), int(13.5 * MM / DZ))
    for env, (per_cell, half) in enumerate(SWEEP):
        region = np.sqrt(intensity[env, rows, samples])
        snr = region.mean() / region.std()
        log_std = (20 * np.log10(region)).std()
        expected = (AMPLITUDE_MEAN ** 2 + AMPLITUDE_STD ** 2) * per_cell * math.erf(half)
        mean = intensity[env, rows, samples].mean()
        print(f"{kind} {per_cell:5d}/cell, half thickness {half} sigma: SNR {snr:.3f}, log std {log_std:.2f} dB, "
              f"mean intensity {mean / expected:.3f} of the incoherent sum")
        assert abs(snr - RAYLEIGH_SNR) <= 0.1, (per_cell, half)
        assert abs(log_std - RAYLEIGH_LOG_STD) <= 0.5, (per_cell, half)
        assert abs(mean / expected - 1) <= 0.15, (per_cell, half)
