"""`cressim demo cautery`: an energized hook coagulates a track across a slab of liver and then
cuts along it. The slab (60 x 40 x 10 mm, 2.5 mm tets, 5 kPa, liver's heat: cressim.Thermal) lies
on a table, its bottom held; a kinematic electrode (cressim.passes.Cautery, 2.5 mm radius, 10 W)
rests on its top and slides 40 mm along x at 10 mm/s in coagulation mode, then back in cut mode.
Each env's camera looks on from above; the saved frames show the track turning pale and then
parting. Prints the peak temperature, the coagulated volume and the cut tets (also in
<out>/cautery_summary.json); saves <out>/cautery_<frame>_rgb.png and <out>/cautery.npz
(temperatures and damage per frame)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

import cressim
from cressim import io
from cressim.passes.cautery import Cautery
from .stage import add_camera_and_sun

HALF = (0.03, 0.02, 0.005)  # m
CELLS = (24, 16, 4)
TOP = 2 * HALF[2]
SPEED, TRACK, RADIUS, POWER = 0.01, 0.04, 0.0025, 10.0  # m/s, m, m, W


def author_env(world, env, table_mesh, width, height, heat=True):
    """One env of the scene: table, liver, hook (returned), camera and sun."""
    table = world.create_entity(env=env, name="table")
    table.add(cressim.Transform())
    table.add(cressim.Collider(cressim.Shape.plane()))
    table.add(cressim.Renderable(table_mesh, color=(0.75, 0.75, 0.78, 1), roughness=0.7))
    mesh = cressim.TetMesh.box(HALF, CELLS)
    rest = np.asarray(mesh.positions)
    liver = world.create_entity(env=env, name="liver")
    liver.add(cressim.Transform(position=(0, 0, HALF[2])))
    liver.add(cressim.SoftBody(mesh, fixed=np.nonzero(rest[:, 2] < -HALF[2] + 1e-6)[0], youngs_modulus=5e3,
                               radius=0.001, damping=5.0, thermal=cressim.Thermal() if heat else None))
    liver.add(cressim.Material(color=(0.28, 0.04, 0.03, 1), roughness=0.45))
    hook = world.create_entity(env=env, name="hook")
    hook.add(cressim.Transform(position=(-TRACK / 2, 0, TOP)))
    hook.add(cressim.RigidBody(kinematic=True, mass=0.01, inertia=(1e-6, 1e-6, 1e-6)))
    hook.add(cressim.Renderable(world.add_mesh(cressim.Mesh.capsule(0.0012, 0.02)), color=(0.8, 0.8, 0.85, 1),
                                metallic=0.9, roughness=0.3))
    add_camera_and_sun(world, env, eye=(0.0, -0.07, 0.08), target=(0.0, 0.0, TOP), sun=(0, 0, 0.3),
                       sun_target=(0.05, 0.03, 0), width=width, height=height, fov_y=50, intensity=2.0,
                       shadow_resolution=256)
    return hook


def run(frames: int = 480, out_dir: str = "out/demo", num_envs: int = 1, images: int = 4, width: int = 320,
        height: int = 240) -> int:
    world = cressim.World(cressim.SceneLayout(num_envs))
    table_mesh = world.add_mesh(cressim.Mesh.plane(0.1))
    hooks = [author_env(world, env, table_mesh, width, height) for env in range(num_envs)]
    engine = cressim.Engine(world)
    engine.physics = cressim.PhysicsSettings(substeps=2, particle_iterations=2)
    engine.prepare()
    engine.upload_world()
    cautery = Cautery(engine, hooks, (0, 0, 0), RADIUS, power=POWER)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    dt = engine.physics.dt
    half = frames // 2
    turn = -TRACK / 2 + min(half * dt * SPEED, TRACK)  # where the way out ends and the way back starts
    shots = set(np.linspace(0, frames - 1, images).astype(int).tolist()) | {half - 1}
    temperatures, damage = [], []
    cautery.set([True] * num_envs)
    for f in range(frames):
        back = f >= half  # coagulate on the way out, cut on the way back
        if f == half:
            cautery.set_mode([True] * num_envs)
        s = min((f - half if back else f) * dt * SPEED, TRACK)
        x = max(turn - s, -TRACK / 2) if back else min(-TRACK / 2 + s, turn)
        for hook in hooks:
            hook.transform = cressim.Transform(position=(x, 0, TOP))
        cautery.execute()
        engine.step_physics()
        engine.end_frame()
        temperatures.append(engine.buffer("particles.temperatures").read().copy())
        damage.append(engine.buffer("particles.damage").read().copy())
        if f in shots:
            engine.step_visual_sensors()
            engine.end_frame()
            io.save_png(out / f"cautery_{f:03d}_rgb.png", engine.buffer("camera0.rgb").read()[0, ..., :3])
    capacities = engine.buffer("particles.heat_capacities").read()
    volume = capacities / (3540.0 * 1000.0)  # m^3 per particle (c rho)
    coagulated = (damage[-1] > 1.0)
    cut = int(engine.buffer("control.particle_tet_cut").read().sum())
    path = out / "cautery.npz"
    np.savez_compressed(path, temperatures=np.array(temperatures), damage=np.array(damage), dt=dt)
    summary = {"envs": num_envs, "frames": frames, "peak_c": float(np.max(temperatures) - 273.15),
               "coagulated_mm3_per_env": float(volume[coagulated].sum() * 1e9 / num_envs),
               "cut_tets_per_env": cut / num_envs, "health_events": int(engine.health_events)}
    (out / "cautery_summary.json").write_text(json.dumps(summary, indent=2))
    print(f"cautery: {num_envs} env(s), {frames} frames; peak {summary['peak_c']:.0f} C, coagulated "
          f"{summary['coagulated_mm3_per_env']:.0f} mm^3 per env (Omega > 1), {summary['cut_tets_per_env']:.0f} tets "
          f"cut per env, health events {summary['health_events']}; wrote {path}, cautery_summary.json and "
          f"{len(shots)} images")
    return 0
