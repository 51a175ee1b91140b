"""Cost of the elastic soft-body material (stable Neo-Hookean, solved per vertex) against the expert
XPBD compliance model on the same mesh, and what each solver knob costs. Per env: a tissue block
(5 x 5 x 5 cells: 216 particles, 750 tets, 40 x 40 x 40 mm, 10 kPa, nu 0.45) clamped at its base
on a plane, with a kinematic sphere pressing into its top (contacts every substep). Env-steps
per second of 60 Hz frames (one submit each, a device wait per frame) and the block's top drop
after the run (the material's answer, the same at every setting). The elastic 4 x 4 row runs in
both particle solver schedules (`workgroup`: one workgroup per env, `dispatch`: one dispatch per
vertex colour).

    PYTHONPATH=python python3 benchmarks/bench_soft_material.py --envs 64,512,4096 --json out.json
"""
import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "python"))

import cressim  # noqa: E402

HALF = 0.02
CELLS = (5, 5, 5)


def build(num_envs: int, model: str):
    world = cressim.World(cressim.SceneLayout(num_envs))
    mesh = cressim.TetMesh.box((HALF, HALF, HALF), CELLS)
    rest = np.asarray(mesh.positions)
    base = np.nonzero(rest[:, 2] < -HALF + 1e-6)[0]
    material = (dict(youngs_modulus=1e4, poisson_ratio=0.45, density=1000.0) if model == "elastic" else
                dict(mass=1000.0 * (2 * HALF) ** 3 / len(rest), distance_compliance=1e-4, volume_compliance=1e-4))
    for env in range(num_envs):
        ground = world.create_entity(env=env, name="ground")
        ground.add(cressim.Transform())
        ground.add(cressim.Collider([cressim.Shape.plane()]))
        block = world.create_entity(env=env, name="tissue")
        block.add(cressim.Transform(position=(0, 0, HALF)))
        block.add(cressim.SoftBody(mesh, fixed=base, radius=0.004, damping=2.0, **material))
        tool = world.create_entity(env=env, name="tool")
        tool.add(cressim.Transform(position=(0, 0, 2 * HALF + 0.008)))
        tool.add(cressim.RigidBody(kinematic=True))
        tool.add(cressim.Collider([cressim.Shape.sphere(0.01)]))
    return world, rest


def run(num_envs: int, model: str, substeps: int, iterations: int, frames: int, device, solver: str = "auto"):
    world, rest = build(num_envs, model)
    engine = cressim.Engine(world, device=device)
    engine.physics = cressim.PhysicsSettings(substeps=substeps, particle_iterations=iterations, particle_solver=solver)
    engine.prepare()
    engine.upload_world()
    for _ in range(10):  # warm-up (pipelines, caches)
        engine.step_physics()
        engine.end_frame()
    t0 = time.perf_counter()
    for _ in range(frames):
        engine.step_physics()
        engine.end_frame()
    elapsed = time.perf_counter() - t0
    p = engine.buffer("particles.positions").read()[:, :3].reshape(num_envs, len(rest), 3)
    top = rest[:, 2] > HALF - 1e-6
    drop = float(((rest[top, 2] + HALF) - p[0][top, 2]).mean())
    return {"envs": num_envs, "model": model, "substeps": substeps, "particle_iterations": iterations,
            "particle_solver": solver,
            "frames": frames, "env_steps_per_s": num_envs * frames / elapsed, "frame_ms": elapsed / frames * 1e3,
            "top_drop_mm": drop * 1e3, "device": engine.device["name"],
            "unhealthy_envs": int((engine.buffer("env.health").read() != 0).sum())}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--envs", default="64,512,4096")
    p.add_argument("--frames", type=int, default=120)
    p.add_argument("--device", default=None)
    p.add_argument("--json", default=None)
    p.add_argument("--schedules-only", action="store_true", help="only the elastic 4 x 4 row in both schedules")
    args = p.parse_args(argv)
    rows = []
    for n in (int(x) for x in args.envs.split(",")):
        for model, substeps, iterations, solver in (
                ("elastic", 4, 4, "auto"), ("elastic", 4, 4, "dispatch"), ("compliance", 4, 4, "auto"),
                ("elastic", 4, 1, "auto"), ("elastic", 8, 2, "auto"), ("elastic", 4, 8, "auto"),
                ("elastic", 16, 1, "auto"))[: 2 if args.schedules_only else None]:
            r = run(n, model, substeps, iterations, args.frames, args.device, solver)
            rows.append(r)
            print(f"{r['device']}: {n:5d} envs {model:10s} substeps {substeps:2d} iterations {iterations} "
                  f"solver {solver:8s}: "
                  f"{r['env_steps_per_s']:12,.0f} env-steps/s ({r['frame_ms']:.2f} ms/frame), top drop "
                  f"{r['top_drop_mm']:.3f} mm, unhealthy {r['unhealthy_envs']}", flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
