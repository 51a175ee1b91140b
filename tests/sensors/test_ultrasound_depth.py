"""Depth dependence of the ultrasound sensor: frequency-dependent attenuation, time-gain
compensation and a focused beam, against their models.

References: the two-way loss of a tissue of attenuation alpha (dB/cm/MHz) at centre frequency
f0 is alpha f0 2 depth dB, so speckle's mean intensity falls by that many dB (10 log10 of the
intensity); a TGC of the same rate makes it flat. A focused Gaussian beam's width grows as
w(z) = w0 sqrt(1 + ((z - F) / z_R)^2), z_R = pi w0^2 / wavelength (w0: one-way 1/e^2 radius,
twice the two-way sigma), and its two-way on-axis amplitude falls as w0 / w(z) per axis.
"""
import math

import numpy as np

import cressim

from .test_ultrasound import FS, FWHM, MM, C, F0, half_max_width, phantom, point, probe, sensed_iq

ON_LINE = 0.075 * MM  # scanline 48 of the test probe: peaks are not cut by a line's lateral offset


def engine_with(make_engine, envs):
    """envs: list of (add tissue(world, env), probe fields), one env each."""
    world = cressim.World(cressim.SceneLayout(len(envs)))
    for env, (tissue, fields) in enumerate(envs):
        tissue(world, env)
        p = world.create_entity(env=env, name="probe")
        p.add(cressim.Transform())
        p.add(probe(**fields))
    return np.abs(sensed_iq(make_engine, world))


def test_attenuation_darkens_speckle_with_depth_and_tgc_flattens_it(make_engine):
    alpha = 2.0  # dB/cm/MHz: 20 dB/cm two-way at 5 MHz, large against the speckle's scatter
    rate = alpha * F0 / 1e6 * 2  # dB per cm of depth
    tissue = lambda w, env: phantom(w, env, density=200e9, attenuation=alpha)  # noqa: E731
    env = engine_with(make_engine, [(tissue, {}), (tissue, {"time_gain_compensation": rate})])
    dz = C / (2 * FS) * 4
    depth = (np.arange(env.shape[2]) + 0.5) * dz
    edges = np.arange(1 * MM, 11 * MM + 1e-9, 0.5 * MM)
    centres = 0.5 * (edges[1:] + edges[:-1]) / (10 * MM)  # cm
    slopes = []
    for e in env:
        db = [10 * np.log10((e[4:92, (depth >= lo) & (depth < hi)] ** 2).mean()) for lo, hi in zip(edges, edges[1:])]
        slopes.append(np.polyfit(centres, db, 1)[0])
    print(f"speckle mean intensity: {slopes[0]:.2f} dB/cm without TGC (model {-rate:.1f}), {slopes[1]:.2f} with")
    assert abs(slopes[0] / -rate - 1) < 0.10
    assert abs(slopes[1]) < 0.10 * rate


def test_focused_beam_is_narrowest_at_the_focus(make_engine):
    focus, away = 6 * MM, 1 * MM
    fields = {"focal_depth": focus, "radial_decimation": 2}
    env = engine_with(make_engine, [(lambda w, e: point(w, e, (ON_LINE, 0, focus)), fields),
                                    (lambda w, e: point(w, e, (ON_LINE, 0, away)), fields),
                                    (lambda w, e: point(w, e, (ON_LINE, 0, away)), {"radial_decimation": 2})])
    wavelength = C / F0

    def growth(width):  # the Gaussian beam's widening at `away` for a two-way FWHM `width`
        w0 = 2 * width / FWHM
        return math.sqrt(1 + ((away - focus) / (math.pi * w0 ** 2 / wavelength)) ** 2)

    widths, peaks = [], []
    for e in env:
        line, sample = np.unravel_index(np.argmax(e), e.shape)
        widths.append(half_max_width(e[:, sample], 0.15 * MM))
        peaks.append(e.max())
    g_lat, g_elev = growth(0.6 * MM), growth(1.0 * MM)
    print(f"lateral FWHM at the focus {widths[0] / MM:.3f} mm (0.6), {focus - away:.0f} mm away "
          f"{widths[1] / MM:.3f} mm (model {0.6 * g_lat:.3f}); unfocused {widths[2] / MM:.3f} mm; peak ratio "
          f"{peaks[1] / peaks[0]:.3f} (model {1 / (g_lat * g_elev):.3f})")
    assert abs(widths[0] / (0.6 * MM) - 1) < 0.10
    assert abs(widths[1] / (0.6 * MM * g_lat) - 1) < 0.10
    assert abs(widths[2] / (0.6 * MM) - 1) < 0.10  # focal_depth 0: the width holds at every depth
    assert abs(peaks[1] / peaks[0] * g_lat * g_elev - 1) < 0.05
