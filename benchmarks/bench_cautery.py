"""Throughput of `cressim demo cautery`'s scene (a 60 x 40 x 10 mm liver slab, 2,125 particles and
9,216 tets an env, an energized hook on it) at several env counts: physics steps with the hook
energized (heat cycles, coagulation pass) against the same slab without heat, env-steps per
second. No rendering (the cameras are authored but not drawn).

    PYTHONPATH=python python3 benchmarks/bench_cautery.py --envs 1,64,1024 [--json OUT]
"""
from __future__ import annotations

import cressim
from cressim.demos import cautery as demo
from cressim.passes.cautery import Cautery
from scene_throughput import main, timed


def measure(envs: int, frames: int, heat: bool) -> dict:
    world = cressim.World(cressim.SceneLayout(envs))
    table_mesh = world.add_mesh(cressim.Mesh.plane(0.1))
    hooks = [demo.author_env(world, env, table_mesh, 64, 48, heat=heat) for env in range(envs)]
    engine = cressim.Engine(world)
    engine.physics = cressim.PhysicsSettings(substeps=2, particle_iterations=2)
    engine.prepare()
    engine.upload_world()
    cautery = None
    if heat:
        cautery = Cautery(engine, hooks, (0, 0, 0), demo.RADIUS, power=demo.POWER)
        cautery.set([True] * envs)

    def frame():
        if cautery:
            cautery.execute()
        engine.step_physics()
        engine.end_frame()

    return timed(engine, frame, envs, frames, heat=heat)


if __name__ == "__main__":
    main(__doc__, measure, frames=200, variants=({"heat": True}, {"heat": False}))
