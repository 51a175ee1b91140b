"""Throughput of the run-time particle edits (issue 5) in a BloodSuction-like scene: per env, a
fluid pool (512 particles, budget 1,024) in an open box fed by an emitter (16 per frame) and a
suction tip (a task pass flagging the fluid inside a 6 cm sphere for removal each frame), next to
a soft beam (6 x 2 x 2 cells) whose constraints crossing a plane are cut at the start. Env-steps
per second with and without the suction pass (the removal pass itself always runs), 60 Hz frames,
2 substeps, 4 particle iterations, a device wait after every frame (one submit each).

    PYTHONPATH=python python3 benchmarks/bench_particle_edits.py --envs 64,256,1024

writes benchmarks/results/particle_edits_<device>.json.
"""
import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "python"))

import cressim  # noqa: E402
from cressim.passes.suction import Suction  # noqa: E402



def build(num_envs):
    world = cressim.World(cressim.SceneLayout(num_envs))
    z, y, x = np.meshgrid(np.arange(8), np.arange(8), np.arange(8), indexing="ij")
    block = (np.stack([x, y, z], -1).reshape(-1, 3) * 0.04 + np.array([-0.14, -0.14, 0.02])).astype(np.float32)
    mesh = cressim.TetMesh.box((0.15, 0.05, 0.05), (6, 2, 2))
    for env in range(num_envs):
        box = world.create_entity(env=env, name="basin")
        box.add(cressim.Transform())
        ix = iy = 0.18
        box.add(cressim.Collider([cressim.Shape.plane()] + [
            cressim.Shape.box((0.05, iy + 0.1, 0.3), position=(s * (ix + 0.05), 0, 0.3)) for s in (-1, 1)] + [
            cressim.Shape.box((ix, 0.05, 0.3), position=(0, s * (iy + 0.05), 0.3)) for s in (-1, 1)]))
        blood = world.create_entity(env=env, name="blood")
        blood.add(cressim.Transform())
        blood.add(cressim.Fluid(block, budget=1024, radius=0.02, emit_rate=16, emit_width=4,
                                emit_origin=(0.08, 0.08, 0.5), emit_velocity=(0, 0, -1)))
        beam = world.create_entity(env=env, name="tissue")
        beam.add(cressim.Transform(position=(0, 0, 0.8)))
        beam.add(cressim.SoftBody(mesh, fixed=np.nonzero(mesh.positions[:, 0] < -0.1499)[0], mass=0.05,
                                  distance_compliance=1e-3, volume_compliance=1e-3))
    engine = cressim.Engine(world)
    engine.physics = cressim.PhysicsSettings(dt=1 / 60, substeps=2, particle_iterations=4,
                                             max_particle_attachments_per_env=0)
    engine.prepare()
    engine.upload_world()
    # cut the beams across x = 0.025 (every env)
    x = engine.buffer("particles.initial_positions").read()[:, 0]
    for family, k in (("distance", 2), ("volume", 4)):
        rec = engine.buffer(f"particles.{family}_constraints").read()[:, :k].astype(np.int64)
        side = x[rec] > 0.025
        engine.cut_constraints(family, np.nonzero(side.any(1) & ~side.all(1))[0])
    n = len(x)
    suction = Suction(engine, None, (-0.06, -0.06, 0.06), 0.06)
    suction.set(np.ones(num_envs, dtype=bool))
    return engine, suction


def measure(num_envs, with_suction, warmup=30, frames=200):
    engine, suction = build(num_envs)

    def frame():
        engine.step_physics()
        if with_suction:
            suction.execute()
        engine.end_frame()

    for _ in range(warmup):
        frame()
    m = engine.particle_mapping
    fluid = m["object_kind"] == m["kinds"]["fluid"]
    emitted0 = int(engine.buffer("particles.emitted").read()[fluid].sum())
    t0 = time.perf_counter()
    for _ in range(frames):
        frame()
    seconds = time.perf_counter() - t0
    active = int(engine.buffer("particles.emitted").read()[fluid].sum())
    return {"envs": num_envs, "suction": with_suction, "env_steps_per_s": num_envs * frames / seconds,
            "ms_per_frame": 1e3 * seconds / frames, "active_fluid_per_env": active / num_envs,
            "active_change_per_env": (active - emitted0) / num_envs, "vulkan_device": engine.device["name"]}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--envs", default="64,256,1024")
    ap.add_argument("--frames", type=int, default=200, help="measured frames (after 30 warm-up frames)")
    ap.add_argument("--out", default="benchmarks/results")
    args = ap.parse_args()
    rows = []
    for n in (int(v) for v in args.envs.split(",")):
        for with_suction in (False, True):
            rows.append(measure(n, with_suction, frames=args.frames))
            r = rows[-1]
            print(f"{n:6d} envs suction={with_suction!s:5}: {r['env_steps_per_s']:10.0f} env-steps/s "
                  f"({r['ms_per_frame']:.2f} ms/frame), {r['active_fluid_per_env']:.0f} active fluid per env", flush=True)
    name = rows[0]["vulkan_device"] if rows else "unknown"
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    stem = "particle_edits_" + "".join(c if c.isalnum() else "-" for c in name.lower()).strip("-")
    (out / f"{stem}.json").write_text(json.dumps({"benchmark": "particle_edits", "device_name": name, "rows": rows},
                                                 indent=1))
    print(f"wrote {out / stem}.json")


if __name__ == "__main__":
    main()
