"""`cressim demo suture`: a running suture across a wound, pulled tight. Two flaps of soft tissue
(24 x 30 x 8 mm each, 10 kPa, 3 mm tets) lie on a table 4 mm apart, each held at its far edge. A
16 mm 3/8 circle needle (cressim.Needle on a kinematic body) carries 160 mm of 2-0 braided thread
(a cressim.Strand of a material), its end a knot. The needle is turned about its centre, so that
its tip runs along its own arc, through the left flap's top, out of its cut face, across the gap,
into the right flap's cut face and out of its top: one bite, four punctures. It is lifted,
carried 10 mm along the wound and turned through a second bite, drawn out along its arc, then
moved along the wound and a little up: the thread runs through until the knot catches at the
first puncture, the loop between the bites is drawn through, and the needle pulls on, slowing as
the thread's tension nears TENSION, until it has held there for HOLD s. The taut thread draws
the tissue it passes toward its line (docs/particles.md, "Suturing"), so the wound narrows at
the bites. Prints the punctures after each bite, when the knot caught, the gap at each bite
before and after, the thread's slack between its punctures after the bites and pulled tight
(its length along the thread less the straight distance: the stitch tightens), the tension
reached and the thread's length (also in <out>/suture_summary.json); saves
<out>/suture_<frame>_rgb.png and <out>/suture.npz (the particle positions at the saved frames)."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

import cressim
from cressim import io
from cressim.suture import PUNCTURED, needle_mesh, punctures, thread_tension
from .stage import add_camera_and_sun

FLAP = (0.012, 0.015, 0.004)  # m: half extents of each flap
CELLS = (8, 10, 3)
GAP = 0.004  # m between the flaps' cut faces
PARTICLE = 0.0012  # m: the tissue's collision radius (the flaps rest on the table by it)
TOP = 2 * FLAP[2] + PARTICLE  # the tissue's top face
RADIUS, ANGLE, HEIGHT = 0.008, 3 * math.pi / 4, 0.003  # the needle's arc; its centre above the tissue's top
THREAD, THREAD_COUNT = 0.16, 81
BITES = (-0.005, 0.005)  # y of each bite
TURN_RATE, LIFT = 2.0, 0.015  # rad/s, m above the bite for the carry
PULL, PULL_SPEED = (0.0, 1.0, 0.2), 0.02  # drawing the thread through: along the wound and a little up, m/s
TENSION, HOLD, PULL_LIMIT = 0.05, 0.5, 10.0  # N the stitch is pulled tight with, s held there; s at most


def _quat(theta):
    """The needle's rotation: its arc plane turned into the world x-z plane (about -y), then theta
    about the arc's axis (the tip leads for increasing theta)."""
    half = math.pi / 4
    qx = (math.sin(half), 0.0, 0.0, math.cos(half))
    qz = (0.0, 0.0, math.sin(theta / 2), math.cos(theta / 2))
    x1, y1, z1, w1 = qx
    x2, y2, z2, w2 = qz
    return (w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2, w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2, w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2)


# the turn that puts the tip just above the left flap's top (it enters at angle pi + asin(H / R))
START = math.pi + math.asin(HEIGHT / RADIUS) - 0.25 - ANGLE
# and the one that has carried the tail well out of the right flap's top (at 2 pi - asin(H / R))
END = 2 * math.pi - math.asin(HEIGHT / RADIUS) + 0.6


def author_env(world, env, meshes, width, height, camera=True, bites=BITES, thread=(THREAD, THREAD_COUNT),
               friction=0.0, squeeze=0.0, table=True):
    """One env: table (or none), two flaps, thread (length m, particles), needle (returned; over
    the first bite; `friction` and `squeeze` its cressim.Needle's), camera and light."""
    top = TOP
    if table:
        plane = world.create_entity(env=env, name="table")
        plane.add(cressim.Transform())
        plane.add(cressim.Collider(cressim.Shape.plane()))
        plane.add(cressim.Renderable(meshes["table"], color=(0.75, 0.78, 0.8, 1), roughness=0.7))
    mesh = cressim.TetMesh.box(FLAP, CELLS)
    rest = np.asarray(mesh.positions)
    for side, name in ((-1, "left_flap"), (1, "right_flap")):
        flap = world.create_entity(env=env, name=name)
        flap.add(cressim.Transform(position=(side * (GAP / 2 + FLAP[0]), 0, FLAP[2] + PARTICLE)))
        far = np.nonzero(side * rest[:, 0] > FLAP[0] - 1e-6)[0]  # the far edge, held
        flap.add(cressim.SoftBody(mesh, fixed=far, youngs_modulus=10e3, poisson_ratio=0.45, density=1050,
                                  radius=PARTICLE, damping=5.0, friction=0.3))
        flap.add(cressim.Material(color=(0.78, 0.45, 0.4, 1), roughness=0.5))
    centre = np.array([0.0, bites[0], top + HEIGHT])
    tail = centre + RADIUS * np.array([math.cos(START), 0.0, math.sin(START)])
    s = np.linspace(0, thread[0], thread[1])[:, None]
    pts = tail + s * np.array([-0.6, 0.0, 0.8])  # trailing up and back from the tail
    strand = world.create_entity(env=env, name="thread")
    # a 2-0 braided suture (0.3 mm across): a rod of a material, so it weighs what the real thread
    # does (0.08 g/m, 100 times lighter than the tissue it is pulled through); a braid bends far
    # more easily than its fibres' modulus says (an effective 50 MPa here)
    strand.add(cressim.Strand(pts.astype(np.float32), radius=0.00015, youngs_modulus=5e7, poisson_ratio=0.4,
                              density=1140, damping=2.0))
    strand.add(cressim.Material(color=(0.25, 0.2, 0.7, 1), roughness=0.6))
    needle = world.create_entity(env=env, name="needle")
    needle.add(cressim.Transform(position=tuple(centre), rotation=_quat(START)))
    needle.add(cressim.RigidBody(kinematic=True, mass=0.001, inertia=(1e-8, 1e-8, 1e-8)))
    needle.add(cressim.Needle(thread=strand, arc_radius=RADIUS, arc_angle=ANGLE, puncture_force=0.5,
                              puncture_depth=0.001, friction=friction, squeeze=squeeze,
                              max_punctures=8))
    needle.add(cressim.Renderable(meshes["needle"], color=(0.85, 0.85, 0.9, 1), metallic=0.9, roughness=0.25))
    if camera:
        add_camera_and_sun(world, env, eye=(0.035, -0.06, 0.06), target=(0.0, 0.0, top), sun=(0.02, -0.03, 0.3),
                           sun_target=(0, 0, 0), width=width, height=height, shadow_extent=0.08)
    return needle


def motion(dt, bites=BITES):
    """The needle's (phase, centre, turn) per frame through the bites (the pull follows the
    thread's tension: pull_tight())."""
    top = TOP
    steps = []
    for k, y in enumerate(bites):
        low = np.array([0.0, y, top + HEIGHT])
        if k > 0:  # carry over from the last bite: up, turn back in the air, along, down
            prev = np.array([0.0, bites[k - 1], top + HEIGHT])
            n = round(0.3 / dt)
            for i in range(n):
                steps.append(("carry", prev + (0, 0, LIFT * (i + 1) / n), END))
            n = round(0.5 / dt)
            for i in range(n):
                steps.append(("carry", prev + (0, 0, LIFT), END + (START - END) * (i + 1) / n))
            n = round(0.3 / dt)
            for i in range(n):
                f = (i + 1) / n
                steps.append(("carry", prev + (0, (y - prev[1]) * f, LIFT), START))
            for i in range(n):
                f = (i + 1) / n
                steps.append(("carry", low + (0, 0, LIFT * (1 - f)), START))
        n = round((END - START) / TURN_RATE / dt)
        for i in range(n):
            steps.append((f"bite{k + 1}", low, START + (END - START) * (i + 1) / n))
    return steps


def gaps(engine, world, bites=BITES):
    """The gap between the flaps' cut faces (m) at each bite's y, on their top layer."""
    m = engine.particle_mapping
    p = engine.buffer("particles.positions").read()[:, :3]
    out = []
    faces = {}
    for e, o, c in zip(m["object_entity"], m["object_offset"], m["object_count"]):
        name = world.entity(int(e)).name
        if name in ("left_flap", "right_flap"):
            faces[name] = p[int(o):int(o) + int(c)]
    top = TOP
    for y in bites:
        def edge(q, inner):
            near = q[(np.abs(q[:, 1] - y) < 0.0031) & (q[:, 2] > top - 0.0035)]
            return near[:, 0].max() if inner == "max" else near[:, 0].min()
        out.append(float(edge(faces["right_flap"], "min") - edge(faces["left_flap"], "max")))
    return out


def needle_out(engine, frame, centre, theta: float, dt: float) -> tuple[float, int]:
    """The needle drawn out along its arc (turned on about its centre, as a surgeon draws it out by
    its tip) until no punctured point is on it (pulled sideways, the needle would drag them), at
    most 1.5 rad more. `frame(centre, theta)` steps a frame. Returns the turn and the frames."""
    n = 0
    while any(r["state"] == PUNCTURED and r["s"] <= RADIUS * ANGLE for r in punctures(engine)[0]) and n * TURN_RATE * dt < 1.5:
        theta += TURN_RATE * dt
        frame(centre, theta)
        n += 1
    return theta, n


def pull_tight(engine, frame, centre, theta: float, dt: float, tension: float, limit: int, each=None,
               speed: float = PULL_SPEED):
    """Draws the thread through and pulls it tight: the needle moves along PULL at up to `speed`
    m/s, the slower the nearer env 0's thread tension (cressim.suture.thread_tension) is to
    `tension` N, backing off at a tenth of that above it (a quarter, tried, let a short thread
    go slack and snap taut again, tearing the tissue away), until the tension has stayed within 10 % of it for HOLD s, or `limit`
    frames. `each(k)` after frame k. Returns the needle's centre, the frames and the tension."""
    way = np.asarray(PULL) / np.linalg.norm(PULL)
    held_for, k, now = 0, 0, 0.0
    while k < limit and held_for < round(HOLD / dt):
        now = float(thread_tension(engine)[0])
        centre = centre + way * speed * float(np.clip(1 - now / tension, -0.1, 1)) * dt
        frame(centre, theta)
        if each is not None:
            each(k)
        held_for = held_for + 1 if abs(now - tension) < 0.1 * tension else 0
        k += 1
    return centre, k, now


def slack(records) -> list[float]:
    """Per stretch of thread between two punctures it runs through (in order along it): its length
    along the thread (the path parameters' difference: rest lengths) less the straight distance
    between the punctured points, m. A stitch pulled tight has none."""
    on_thread = sorted((r for r in records if r["state"] == PUNCTURED and r["s"] > RADIUS * ANGLE),
                       key=lambda r: r["s"])
    return [float(b["s"] - a["s"] - np.linalg.norm(b["point"] - a["point"])) for a, b in zip(on_thread, on_thread[1:])]


def run(frames: int | None = None, out_dir: str = "out/demo", num_envs: int = 1, images: int = 6, width: int = 480,
        height: int = 360) -> int:
    world = cressim.World(cressim.SceneLayout(num_envs))
    meshes = {"table": world.add_mesh(cressim.Mesh.plane(0.1)), "needle": world.add_mesh(needle_mesh(RADIUS, ANGLE, 0.00035))}
    needles = [author_env(world, env, meshes, width, height, camera=True) for env in range(num_envs)]
    engine = cressim.Engine(world)
    engine.prepare()
    engine.upload_world()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    dt = engine.physics.dt
    steps = motion(dt)
    if frames is not None:
        steps = steps[:frames]
    before = gaps(engine, world)
    shots = set(np.linspace(0, len(steps) - 1, images - 2).astype(int).tolist())
    shots |= {i for i in range(len(steps)) if i + 1 == len(steps) or steps[i + 1][0] != steps[i][0]}
    saved, after_bites = {}, {}
    m = engine.particle_mapping
    thread = [(int(o), int(c)) for e, o, c in zip(m["object_entity"], m["object_offset"], m["object_count"])
              if world.entity(int(e)).name == "thread"][0]

    def shoot(f):
        engine.step_visual_sensors()
        engine.end_frame()
        io.save_png(out / f"suture_{f:03d}_rgb.png", engine.buffer("camera0.rgb").read()[0, ..., :3])
        saved[f] = engine.buffer("particles.positions").read()[:, :3].copy()

    def knot():
        """The punctured point the knot holds in env 0, or None."""
        held = [r for r in punctures(engine)[0] if r["state"] == PUNCTURED and r["knot"]]
        return held[0]["point"] if held else None

    def frame(centre, theta):
        for needle in needles:
            needle.transform = cressim.Transform(position=tuple(centre), rotation=_quat(theta))
        engine.step_physics()
        engine.end_frame()

    for f, (phase, centre, theta) in enumerate(steps):
        frame(centre, theta)
        if f + 1 == len(steps) or steps[f + 1][0] != phase:
            after_bites[phase] = sum(1 for r in punctures(engine)[0] if r["state"] == PUNCTURED)
            loose = slack(punctures(engine)[0])
        if f in shots:
            shoot(f)
    f, centre, theta = len(steps), steps[-1][1], steps[-1][2]
    theta, n = needle_out(engine, frame, centre, theta, dt)
    f += n
    caught, caught_at = None, None

    def watch(k):
        nonlocal caught, caught_at
        if caught is None:
            caught = knot()
            if caught is not None:
                caught_at = f + k
                shoot(f + k)

    centre, n, tension = pull_tight(engine, frame, centre, theta, dt, TENSION,
                                    limit=(frames - f) if frames is not None else round(PULL_LIMIT / dt), each=watch)
    f += n
    shoot(f)
    held = knot()
    after = gaps(engine, world)
    records = punctures(engine)[0]
    tp = engine.buffer("particles.positions").read()[thread[0]:thread[0] + thread[1], :3]
    length = float(np.linalg.norm(np.diff(tp, axis=0), axis=1).sum())
    np.savez_compressed(out / "suture.npz", frames=np.array(sorted(saved)), positions=np.array([saved[k] for k in sorted(saved)]),
                        dt=dt)
    summary = {"envs": num_envs, "frames": f, "punctures_after_each_bite": after_bites,
               "punctures": len([r for r in records if r["state"] == PUNCTURED]),
               "knot_caught_at_frame": caught_at, "knot_holds": held is not None,
               "knot_pulled_tissue_mm": float(np.linalg.norm(held - caught) * 1e3) if held is not None and caught is not None else 0.0,
               "gap_before_mm": [g * 1e3 for g in before], "gap_after_mm": [g * 1e3 for g in after],
               "thread_length_mm": length * 1e3, "thread_rest_length_mm": THREAD * 1e3,
               "slack_after_bites_mm": [v * 1e3 for v in loose], "slack_tight_mm": [v * 1e3 for v in slack(records)],
               "tension_n": tension, "tension_target_n": TENSION,
               "health_events": int(engine.health_events)}
    (out / "suture_summary.json").write_text(json.dumps(summary, indent=2))
    print(f"suture: {num_envs} env(s), {f} frames; punctured points after each bite {after_bites}; the knot caught "
          f"at frame {caught_at} and {'holds' if held is not None else 'does not hold'}, drawing the tissue there "
          f"{summary['knot_pulled_tissue_mm']:.1f} mm; gap at the bites {', '.join(f'{a:.1f}' for a in summary['gap_before_mm'])}"
          f" mm -> {', '.join(f'{a:.1f}' for a in summary['gap_after_mm'])} mm; thread {length * 1e3:.1f} mm (authored "
          f"{THREAD * 1e3:.0f}); slack between punctures {sum(loose) * 1e3:.1f} mm after the bites, "
          f"{sum(slack(records)) * 1e3:.1f} mm pulled tight to {tension:.3f} N; health events {summary['health_events']}; wrote {out / 'suture_summary.json'} and "
          f"{len(saved)} images")
    return 0
