"""`cressim demo cable`: a cable-driven continuum robot. A 100 mm superelastic NiTi backbone (1 mm
across, a rod of a material: E 50 GPa, a cressim.Strand of 21 particles) sticks out of a base along
+x, clamped at its first segment; 11 spacer disks (every other particle, 5 mm radius) carry four
tendons at 4 mm from the backbone, 90 degrees apart (cressim.Tendons), in antagonistic pairs.
1. Tendon 0 is pulled in 1, 2 and 3 mm (its opposite let out as much), each held 0.75 s: the
   constant-curvature model says the tip turns d / r (0.25, 0.5, 0.75 rad).
2. The pulls go round, (a cos phi, a sin phi) on the two pairs with a = 3 mm, once in 2 s: the tip
   sweeps a circle.
3. Tendon 0 alone pulls with a tension of 6 N (the others slack), first free, then with a 10 g
   weight at the tip: the planar elastica (a uniform moment T r and the dead load) says where the
   tip goes.
Prints the measured turns and tip positions against the references (also in
<out>/cable_summary.json); saves <out>/cable_<frame>_rgb.png from the camera (the disks and
tendons are drawn as visuals placed from the physics each frame), <out>/cable_curvature.png (the
backbone, disks and tendon routes at the three pulls over the constant-curvature arcs) and
<out>/cable.npz (the backbone and tendon states per frame)."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

import cressim
from cressim import io
from cressim.tendons import TendonDrive
from .stage import add_camera_and_sun

LENGTH, COUNT, EVERY = 0.1, 21, 2  # m, backbone particles, a disk every other one
OFFSET, DISK_RADIUS, HEIGHT = 0.004, 0.005, 0.08  # m
NITINOL = {"youngs_modulus": 50e9, "poisson_ratio": 0.33, "density": 6450, "radius": 0.0005}
HOLES = [(OFFSET, 0), (0, OFFSET), (-OFFSET, 0), (0, -OFFSET)]
PULLS, HOLD = (0.001, 0.002, 0.003), 0.75  # m, s
SWEEP, SWEEP_TIME = 0.003, 2.0  # m, s
TENSION, WEIGHT = 6.0, 0.010  # N, kg


def disks() -> list[int]:
    return list(range(0, COUNT, EVERY)) + ([COUNT - 1] if (COUNT - 1) % EVERY else [])


def author_env(world, env, meshes, width, height, visuals=False):
    """One env: table, base, robot; with `visuals`, a camera, a light and the disk and tendon
    visuals (returned: lists of entities)."""
    table = world.create_entity(env=env, name="table")
    table.add(cressim.Transform())
    table.add(cressim.Collider(cressim.Shape.plane()))
    table.add(cressim.Renderable(meshes["table"], color=(0.75, 0.75, 0.78, 1), roughness=0.7))
    base = world.create_entity(env=env, name="base")
    base.add(cressim.Transform(position=(-0.012, 0, HEIGHT)))
    base.add(cressim.Renderable(meshes["base"], color=(0.2, 0.22, 0.25, 1), metallic=0.3, roughness=0.5))
    s = np.linspace(0, LENGTH, COUNT)
    robot = world.create_entity(env=env, name="robot")
    robot.add(cressim.Transform(position=(0, 0, HEIGHT)))
    robot.add(cressim.Strand(np.stack([s, 0 * s, 0 * s], 1).astype(np.float32), fixed=[0, 1], damping=20, **NITINOL))
    robot.add(cressim.Tendons(disks(), np.asarray(HOLES, np.float32)))
    robot.add(cressim.Material(color=(0.7, 0.7, 0.72, 1), metallic=0.9, roughness=0.3))
    if not visuals:
        return None
    add_camera_and_sun(world, env, eye=(0.075, -0.105, 0.125), target=(0.055, 0.0, HEIGHT - 0.015),
                       sun=(0.05, -0.05, 0.4), sun_target=(0.05, 0, 0), width=width, height=height, shadow_extent=0.15)
    plates = []
    for k in range(len(disks())):
        d = world.create_entity(env=env, name=f"disk{k}")
        d.add(cressim.Transform(position=(0, 0, -1)))
        d.add(cressim.Renderable(meshes["disk"], color=(0.85, 0.55, 0.15, 1), roughness=0.4))
        plates.append(d)
    colours = [(0.8, 0.1, 0.1, 1), (0.1, 0.6, 0.1, 1), (0.1, 0.2, 0.8, 1), (0.9, 0.9, 0.1, 1)]
    spans = []
    for t in range(len(HOLES)):
        row = []
        for k in range(len(disks()) - 1):
            c = world.create_entity(env=env, name=f"tendon{t}_{k}")
            c.add(cressim.Transform(position=(0, 0, -1)))
            c.add(cressim.Renderable(meshes["cable"], color=colours[t], roughness=0.5))
            row.append(c)
        spans.append(row)
    return plates, spans


def disk_mesh(radius, thickness, segments=32) -> cressim.Mesh:
    """A flat cylinder along z (a spacer disk)."""
    a = np.linspace(0, 2 * np.pi, segments, endpoint=False)
    ring = np.stack([radius * np.cos(a), radius * np.sin(a), np.zeros(segments)], 1)
    h = thickness / 2
    pos, nrm, tri = [], [], []
    for z, n in ((h, 1), (-h, -1)):  # caps: a centre and the ring
        base = len(pos)
        pos += [(0, 0, z)] + [tuple(p + (0, 0, z)) for p in ring]
        nrm += [(0, 0, n)] * (segments + 1)
        for i in range(segments):
            j = (i + 1) % segments
            tri.append((base, base + 1 + i, base + 1 + j) if n > 0 else (base, base + 1 + j, base + 1 + i))
    base = len(pos)
    for i in range(segments):  # the rim
        pos += [tuple(ring[i] + (0, 0, h)), tuple(ring[i] + (0, 0, -h))]
        nrm += [tuple(ring[i] / radius)] * 2
    for i in range(segments):
        j = (i + 1) % segments
        a0, a1, b0, b1 = base + 2 * i, base + 2 * i + 1, base + 2 * j, base + 2 * j + 1
        tri += [(a0, a1, b1), (a0, b1, b0)]
    return cressim.Mesh(np.asarray(pos, np.float32), np.asarray(tri, np.uint32), np.asarray(nrm, np.float32))


def _rotate(q, v):
    u, w = q[..., :3], q[..., 3:4]
    t = 2 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def _quat_from_z(d):
    """The rotation taking +z onto unit d (xyzw)."""
    if d[2] < -0.999999:
        return (1.0, 0.0, 0.0, 0.0)
    q = np.array([-d[1], d[0], 0.0, 1 + d[2]])
    return tuple(q / np.linalg.norm(q))


def holes(engine, env=0):
    """(tendons, disks, 3) hole positions and (disks, 3) centres, (disks, 4) frames of env `env`."""
    envs = engine.buffer("particles.env_ranges").shape[0]
    p = engine.buffer("particles.positions").read()[:, :3].reshape(envs, COUNT, 3)[env]
    q = engine.buffer("particles.orientations").read().reshape(envs, COUNT - 1, 4)[env]
    idx = np.array(disks())
    frames = q[np.minimum(idx, COUNT - 2)]
    centres = p[idx]
    out = np.stack([centres + _rotate(frames, np.array([x, y, 0.0])) for x, y in HOLES])
    return out, centres, frames


def tip_turn(engine, env=0):
    _, _, frames = holes(engine, env)
    base, tip = _rotate(frames[0], np.array([0, 0, 1.0])), _rotate(frames[-1], np.array([0, 0, 1.0]))
    return math.atan2(np.linalg.norm(np.cross(base, tip)), float(base @ tip))


def place_visuals(engine, plates, spans):
    hole_pos, centres, frames = holes(engine)
    for d, c, q in zip(plates, centres, frames):
        d.transform = cressim.Transform(position=tuple(c), rotation=tuple(q))
    for t, row in enumerate(spans):
        for k, span in enumerate(row):
            a, b = hole_pos[t, k], hole_pos[t, k + 1]
            v = b - a
            n = float(np.linalg.norm(v))
            span.transform = cressim.Transform(position=tuple((a + b) / 2), rotation=_quat_from_z(v / max(n, 1e-9)),
                                               scale=(1.0, 1.0, n / 0.01))


def plot_shapes(path, shapes):
    """The backbone, disks and tendon 0's route at each pull over the constant-curvature arc."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 4.5), dpi=120)
    for d, (p, h) in shapes.items():
        line, = ax.plot(p[:, 0] * 1e3, (p[:, 2] - HEIGHT) * 1e3, "o-", ms=2.5, label=f"pulled {d * 1e3:.0f} mm")
        ax.plot(h[:, 0] * 1e3, (h[:, 2] - HEIGHT) * 1e3, "--", lw=0.8, color=line.get_color())
        theta, seg = d / OFFSET, LENGTH / (COUNT - 1)
        s = np.linspace(0, LENGTH - seg, 100)
        radius = (LENGTH - seg) / theta
        # the arc from the clamp's end (the first segment stays straight)
        x, z = seg + radius * np.sin(s / radius), -radius * (1 - np.cos(s / radius))
        ax.plot(x * 1e3, z * 1e3, ":", color="k", lw=1)
    ax.plot([], [], ":", color="k", label="constant curvature, d / r")
    ax.plot([], [], "--", color="grey", lw=0.8, label="tendon 0's route")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("z (mm)")
    ax.set_aspect("equal")
    ax.legend(fontsize=8)
    ax.set_title("NiTi backbone, tendon at 4 mm, pulled in d")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def run(frames: int | None = None, out_dir: str = "out/demo", num_envs: int = 1, images: int = 6, width: int = 480,
        height: int = 360) -> int:
    # env 0's disks and tendon spans are renderables of their own
    world = cressim.World(cressim.SceneLayout(num_envs, max_renderables_per_env=64))
    meshes = {"table": world.add_mesh(cressim.Mesh.plane(0.2)), "base": world.add_mesh(cressim.Mesh.box((0.012, 0.02, 0.02))),
              "disk": world.add_mesh(disk_mesh(DISK_RADIUS, 0.0012)), "cable": world.add_mesh(cressim.Mesh.capsule(0.0004, 0.005))}
    visuals = [author_env(world, env, meshes, width, height, visuals=(env == 0)) for env in range(num_envs)][0]
    engine = cressim.Engine(world)
    engine.prepare()
    engine.upload_world()
    drive = TendonDrive(engine)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    dt = engine.physics.dt
    hold, sweep = round(HOLD / dt), round(SWEEP_TIME / dt)
    phases = [("pull", d) for d in PULLS for _ in range(hold)]
    phases += [("sweep", k / sweep) for k in range(sweep)] + [("settle", 0)] * round(0.5 / dt)
    phases += [("tension", 0.0)] * round(1.0 / dt) + [("tension", WEIGHT)] * round(1.0 / dt)
    total = frames if frames is not None else len(phases)
    phases = phases[:total]
    shots = set(np.linspace(0, len(phases) - 1, images).astype(int).tolist())
    shots |= {i for i in range(1, len(phases)) if phases[i][0] != phases[i - 1][0] or phases[i][1] != phases[i - 1][1]
              and phases[i][0] == "pull"}
    shots = {i - 1 for i in shots if i > 0} | {len(phases) - 1}
    tips, lengths, tensions, shapes, turns, results = [], [], [], {}, {}, {}
    forces = np.zeros((engine.buffer("particles.positions").shape[0], 4), np.float32)
    for f, (kind, value) in enumerate(phases):
        if kind == "pull":
            drive.pull([value, 0, -value, 0])
        elif kind == "sweep":
            a, b = SWEEP * math.cos(2 * math.pi * value), SWEEP * math.sin(2 * math.pi * value)
            drive.pull([a, b, -a, -b])
        elif kind == "settle":
            drive.pull([SWEEP, 0, -SWEEP, 0])
        else:
            drive.tension([TENSION, 0, 0, 0])
            forces[COUNT - 1::COUNT, 2] = -value * 9.81
            engine.buffer("control.particle_forces").write(forces)
        engine.step_physics()
        engine.end_frame()
        p = engine.buffer("particles.positions").read()[:, :3].reshape(num_envs, COUNT, 3)
        tips.append(p[:, -1].copy())
        lengths.append(drive.lengths())
        tensions.append(drive.tensions())
        last = f + 1 == len(phases) or phases[f + 1] != (kind, value)
        if last and kind == "pull":
            turns[value] = tip_turn(engine)
            shapes[value] = (p[0].copy(), holes(engine)[0][0].copy())
        if last and kind == "tension":
            results[value] = (p[0, -1] - p[0, 1]).copy()
        if f in shots and visuals is not None:
            place_visuals(engine, *visuals)
            engine.step_visual_sensors()
            engine.end_frame()
            io.save_png(out / f"cable_{f:03d}_rgb.png", engine.buffer("camera0.rgb").read()[0, ..., :3])
    if shapes:
        plot_shapes(out / "cable_curvature.png", shapes)
    tips = np.array(tips)
    np.savez_compressed(out / "cable.npz", tips=tips, lengths=np.array(lengths), tensions=np.array(tensions), dt=dt)
    summary = {"envs": num_envs, "frames": len(phases), "health_events": int(engine.health_events),
               "turns_rad": {f"{d * 1e3:.0f} mm": {"measured": t, "d_over_r": d / OFFSET} for d, t in turns.items()}}
    sweep_tips = tips[[i for i, ph in enumerate(phases) if ph[0] == "sweep"], 0]
    if len(sweep_tips):
        centre = sweep_tips.mean(0)
        summary["sweep_radius_mm"] = float(np.linalg.norm((sweep_tips - centre)[:, 1:], axis=1).mean() * 1e3)
    if results:
        try:  # the reference needs scipy (installed with the test extras)
            from cressim.demos.elastica import cantilever_tip as reference
        except ImportError:
            reference = None
        EI = NITINOL["youngs_modulus"] * math.pi * NITINOL["radius"] ** 4 / 4
        seg = LENGTH / (COUNT - 1)
        summary["tension"] = {}
        for w, tip in results.items():
            row = {"tip_mm": [float(tip[0] * 1e3), float(tip[2] * 1e3)]}
            if reference:
                ref = reference(LENGTH - seg, EI, moment=TENSION * OFFSET, load=w * 9.81)
                row["elastica_mm"] = [float(ref[0] * 1e3), float(ref[1] * 1e3)]
            summary["tension"][f"{w * 1e3:.0f} g"] = row
    (out / "cable_summary.json").write_text(json.dumps(summary, indent=2))
    text = ", ".join(f"pulled {k}: turned {v['measured']:.3f} rad (d/r {v['d_over_r']:.3f})"
                     for k, v in summary["turns_rad"].items())
    print(f"cable: {num_envs} env(s), {len(phases)} frames; {text}; sweep radius "
          f"{summary.get('sweep_radius_mm', float('nan')):.1f} mm; tension {TENSION} N: "
          + "; ".join(f"{k} at the tip -> tip {v['tip_mm'][0]:.1f}, {v['tip_mm'][1]:.1f} mm"
                      + (f" (elastica {v['elastica_mm'][0]:.1f}, {v['elastica_mm'][1]:.1f})" if "elastica_mm" in v else "")
                      for k, v in summary.get("tension", {}).items())
          + f"; health events {summary['health_events']}; wrote {out / 'cable_summary.json'}")
    return 0

