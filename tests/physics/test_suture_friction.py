"""A thread sliding through its punctures (cressim.Needle's `friction` and `squeeze`;
particle_needle_solve.comp.hlsl), on lavapipe. Checked: a frictionless puncture (the pulley), the
thread's path whenever `squeeze` is 0 (the default and every shipped scene), and with squeeze > 0
(friction on the thread) Coulomb's threshold of a straight pass and the capstan law at a turn, with
a rope (docs/particles.md, "Suturing"). The needle of
test_suture bites through the block's top and on, so that its thread runs in at one point of the
top, along a straight tunnel under it and out at another. With gravity along +z (away from the
top) the thread's far end hangs straight "up" out of the entry, and the needle, above the exit, pulls
the thread out slowly: the thread turns a right angle at each puncture (a half turn in all) and
slides through both. The tensions are read from the force each puncture puts on the thread, split
along the thread's two directions there."""
import math

import numpy as np
import pytest

import cressim
from cressim.suture import punctures

from .particle_scenes import positions, step
from .test_suture import A, H, R, quat, scene, turn

G = 9.81
DENSITY = 2e4  # kg/m^3: a heavy thread (1.4 g/m), so that its hanging end's weight is a clear load
THREAD = 0.06


def path_point(thread, s):
    """The thread's point at path parameter s (the needle's length, then along the thread)."""
    at = R * A + np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(thread, axis=0), axis=1))])
    i = int(np.clip(np.searchsorted(at, s) - 1, 0, len(thread) - 2))
    f = np.clip((s - at[i]) / (at[i + 1] - at[i]), 0.0, 1.0)
    return thread[i] + f * (thread[i + 1] - thread[i])


def tensions(record, thread, span=0.003):
    """(T toward the needle, T toward the knot, the thread's turn there): the puncture's force on the
    thread balances the two tensions, F = -(T_a u_a + T_b u_b), solved by least squares."""
    x, s = record["point"], record["s"]
    ua = path_point(thread, s - span) - x
    ub = path_point(thread, s + span) - x
    ua, ub = ua / np.linalg.norm(ua), ub / np.linalg.norm(ub)
    (ta, tb), *_ = np.linalg.lstsq(np.stack([ua, ub], 1), -record["force"], rcond=None)
    return ta, tb, math.pi - math.acos(np.clip(ua @ ub, -1, 1))


def pulled_through(make_engine, mu, squeeze):
    """The bite, the thread settled, then pulled 10 mm up at 10 mm/s; the punctures and thread."""
    engine, needles, tissue = scene(make_engine, density=DENSITY, thread_length=THREAD, friction=mu, squeeze=squeeze)
    theta = 2 * math.pi + 0.5
    turn(engine, needles, to=theta)
    engine.physics = cressim.PhysicsSettings(gravity=(0, 0, G))  # the bite in zero g, as test_suture's
    dt = engine.physics.dt
    # the tail straight above the exit (x = sqrt(R^2 - H^2))
    centre = np.array([math.sqrt(R * R - H * H) - R * math.cos(theta), 0.0, H])
    start = punctures(engine)[0]
    for f in range(int(round(1.5 / dt))):
        if f >= int(round(0.7 / dt)):  # the thread left to hang, then pulled up at 10 mm/s
            centre = centre + np.array([0.0, 0.0, 0.01 * dt])
        needles[0].transform = cressim.Transform(position=tuple(float(v) for v in centre), rotation=quat(theta))
        engine.step_physics()
        engine.end_frame()
    records = sorted(punctures(engine)[0], key=lambda r: r["s"])
    return records, start, positions(engine)[tissue:]


def test_a_frictionless_puncture_passes_the_tension_on_as_a_pulley(make_engine):
    records, start, thread = pulled_through(make_engine, 0.0, 0.0)
    assert len(records) == 2 and not any(r["knot"] for r in records)
    exit_, entry = records
    # it slid: the thread drawn in through the entry by most of the needle's 8 mm
    assert entry["s"] - max(r["s"] for r in start) > 0.004
    t_needle, t_tunnel_exit, turn_exit = tensions(exit_, thread)
    t_tunnel_entry, t_hanging, turn_entry = tensions(entry, thread)
    assert 0.5 < turn_exit < 2.0 and 0.5 < turn_entry < 2.0  # it turns at each (measured 0.75, 0.70 rad)
    # within 20 % (the thread is a rod: its bending at the turns carries a little of the load)
    print(f"needle {t_needle * 1e3:.3f} | exit | {t_tunnel_exit * 1e3:.3f}, tunnel {t_tunnel_entry * 1e3:.3f} | entry | "
          f"{t_hanging * 1e3:.3f} hanging (mN)")
    assert t_needle == pytest.approx(t_tunnel_exit, rel=0.2)
    assert t_tunnel_entry == pytest.approx(t_hanging, rel=0.2)
    assert t_tunnel_exit == pytest.approx(t_tunnel_entry, rel=0.2)


MASS = 3e-6  # kg a particle (1.5 g/m): its own weight is the load
# a thread with no bending or twisting stiffness to speak of (a rope: the friction alone holds it)
ROPE = {"mass": MASS, "bend_compliance": 1e9, "twist_compliance": 1e9, "damping": 10.0, "soft_body_contacts": False}
# the scenes' thread (a 2-0 braid: 0.15 mm radius, 50 MPa, a rod that bends stiffly), as heavy as the rope
BRAID = {"youngs_modulus": 5e7, "poisson_ratio": 0.4, "density": MASS / (0.002 * math.pi * 0.00015 ** 2), "damping": 2.0,
         "soft_body_contacts": False}
THREADS = pytest.mark.parametrize("strand", [ROPE, BRAID], ids=["rope", "braid"])


@THREADS
def test_a_straight_pass_holds_the_thread_up_to_coulombs_limit(make_engine, strand):
    """Coulomb's threshold: the bite's thread laid straight along the line of its two punctures (no
    turn), cut loose from the needle, and loaded along that line by its own weight with g raised
    slowly from 0: it holds while the weight beyond the exit, W, is below 2 mu N (N per puncture)
    and slides from there (within 10 %; measured onset 1.04 x)."""
    mu, squeeze, past = 0.3, 0.0015, 0.0033
    engine, needles, tissue = scene(make_engine, friction=mu, squeeze=squeeze, strand=strand)
    dt = engine.physics.dt
    theta = 2 * math.pi - math.asin(H / R) + past / R  # the tail 3.3 mm (along the arc) past the exit
    turn(engine, needles, to=theta)
    # the needle turned about its tail, arc up, the tail just past the exit on the line of the
    # punctures (the tip stays above the block); then the thread's first segment is cut
    x_exit = math.sqrt(R * R - H * H)
    tail = np.array([x_exit + past - 0.0002, 0.0, 0.0003])
    frames = int(round(0.3 / dt))
    for f in range(frames):
        t = (f + 1) / frames
        centre = np.array([0.0, 0.0, H]) + t * (tail + np.array([0.0, 0.0, R]) - np.array([0.0, 0.0, H]))
        needles[0].transform = cressim.Transform(position=tuple(float(v) for v in centre),
                                                 rotation=quat(theta + t * (1.5 * math.pi - theta)))
        engine.step_physics()
        engine.end_frame()
    for family in ("stretch", "stretch_shear", "bend", "bend_twist"):
        if engine.buffer(f"particles.{family}_constraints").shape[0]:  # the families the thread has
            engine.cut_constraints(family, [0])
    step(engine, 6)
    exit_, entry = sorted(punctures(engine)[0], key=lambda r: r["s"])
    assert exit_["s"] - R * A > 0.002  # past the cut segment
    beyond = sum(1 for k in range(31) if 0.002 * k > exit_["s"] - R * A)  # particles beyond the exit
    start_s = entry["s"]
    limit_g = 2 * mu * squeeze / (beyond * MASS)
    frames = int(round(0.75 / dt))
    onset = None
    for f in range(frames):
        g = 1.5 * limit_g * (f + 1) / frames
        engine.physics = cressim.PhysicsSettings(gravity=(-g, 0, 0))  # along the punctures' line
        step(engine, 1)
        records = sorted(punctures(engine)[0], key=lambda r: r["s"])
        if start_s - records[1]["s"] > 0.0003:  # the thread's material point at the entry moved on
            onset = g
            break
    assert onset is not None, "the thread held at 1.5 x its Coulomb limit"
    print(f"onset at {onset / limit_g:.3f} x 2 mu N, friction {[round(r['friction'] * 1e3, 3) for r in records]} mN")
    assert onset / limit_g == pytest.approx(1.0, abs=0.1)
    # at the onset both punctures pass on their full mu N (the force they report along the thread)
    for r in records:
        assert abs(r["friction"]) == pytest.approx(mu * squeeze, rel=0.1)


def rope_state(engine, first, count=31, rest=0.002):
    """The rope's particles and each segment's tension (N) from its stretch multiplier over the
    last substep, T = -lambda / (L h^2) (the thread is the scene's one strand)."""
    settings = engine.physics
    h = settings.dt / (settings.particle_substeps or settings.substeps)
    lam = engine.buffer("particles.stretch_lambdas").read()[:count - 1]
    return positions(engine)[first:first + count], -lam / (rest * h * h)


def either_side(record, x, tension, rest=0.002):
    """(T toward the needle, T toward the knot, the thread's turn there): the segments either side of
    the one the puncture's material point s lies on."""
    i = int((record["s"] - R * A) // rest)
    ua, ub = x[i - 1] - x[i], x[i + 2] - x[i + 1]
    cos = ua @ ub / (np.linalg.norm(ua) * np.linalg.norm(ub))
    return tension[i - 1], tension[i + 1], math.pi - math.acos(np.clip(cos, -1, 1))


@THREADS
def test_a_turn_at_a_puncture_holds_by_the_capstan_law(make_engine, strand):
    """The capstan law: the bite's rope, gravity along +z so that its end hangs out of the entry, the
    needle above the exit pulled up slowly (5 mm/s): the rope turns at each puncture (1.15 and 1.30
    rad) and holds until the tension toward the needle is exp(mu theta) times the other; the ratio
    each puncture holds up to (the frame before it slips) is that within 10 % (measured -3.0 % at
    the exit, +3.2 % at the entry). Tensions from the rope's stretch multipliers, theta from its
    segments either side; squeeze negligible (mu N = 3e-7 N)."""
    mu = 0.3
    engine, needles, tissue = scene(make_engine, friction=mu, squeeze=1e-6, strand=strand)
    theta = 2 * math.pi + 0.5
    turn(engine, needles, to=theta)
    engine.physics = cressim.PhysicsSettings(gravity=(0, 0, G))  # the bite in zero g, as test_suture's
    dt = engine.physics.dt
    centre = np.array([math.sqrt(R * R - H * H) - R * math.cos(theta), 0.0, H])  # the tail above the exit
    onsets, last = {}, {}
    for f in range(int(round(2.0 / dt))):
        pulling = f >= int(round(0.7 / dt))  # the rope left to hang, then pulled up
        if pulling:
            centre = centre + np.array([0.0, 0.0, 0.005 * dt])
        needles[0].transform = cressim.Transform(position=tuple(float(v) for v in centre), rotation=quat(theta))
        step(engine, 1)
        records = sorted(punctures(engine)[0], key=lambda r: r["s"])
        assert len(records) == 2
        if not pulling:
            held = [r["s"] for r in records]
            continue
        x, tension = rope_state(engine, tissue)
        for k, r in enumerate(records):
            if k in onsets:
                continue
            if abs(r["s"] - held[k]) > 1e-4:  # it slipped: the ratio it held up to, the frame before
                onsets[k] = last[k]
            t_needle, t_knot, turned = either_side(r, x, tension)
            last[k] = (t_needle / t_knot, math.exp(mu * turned), turned)
        if len(onsets) == 2:
            break
    print({("exit", "entry")[k]: tuple(round(v, 3) for v in o) for k, o in onsets.items()})
    assert len(onsets) == 2, "a puncture never slipped"
    for ratio, capstan, turned in onsets.values():
        assert 0.4 < turned < 2.0  # a clear turn (exp(mu theta) 1.13-1.82; the stiff braid turns less)
        assert ratio == pytest.approx(capstan, rel=0.1)
