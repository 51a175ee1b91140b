"""Particle demos: a soft cube dropped on a rigid box (`soft`), a fluid column collapsing in an
open box (`fluid`), and a thread hanging from a moving kinematic needle holder (`thread`).
Each saves the particle states of every frame to <out>/<name>.npz (positions (frames, n, 3),
velocities, the surface triangles and the object layout) for a renderer or a plot, and a few
frames of env 0's camera, drawn from the physics buffers: <out>/<name>_<frame>_rgb.png and
_segmentation.png."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

import cressim
from cressim import io
from .stage import add_camera_and_sun


def _lattice(counts, spacing, origin):
    nx, ny, nz = counts
    z, y, x = np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij")
    return (np.stack([x, y, z], -1).reshape(-1, 3) * spacing + np.asarray(origin)).astype(np.float32)


def _ground(world, env, floor):
    g = world.create_entity(env=env, name="ground")
    g.add(cressim.Transform())
    g.add(cressim.Collider(cressim.Shape.plane()))
    g.add(cressim.Renderable(floor[0], texture=floor[1], roughness=0.8))


# camera (eye, target) per scene, a sun with shadows
VIEWS = {"soft": ((-0.7, -0.8, 0.6), (0.05, 0, 0.15)), "fluid": ((0.8, -0.9, 0.8), (0, 0, 0.1)),
         "thread": ((0.0, -0.7, 0.35), (0.0, 0, 0.3))}


def _camera_and_light(world, env, name, width, height):
    eye, target = VIEWS[name]
    add_camera_and_sun(world, env, eye=eye, target=target, sun=(0, 0, 1), sun_target=(0.4, 0.3, 0), width=width,
                       height=height, fov_y=50, intensity=2.0, shadow_extent=0.8, shadow_resolution=256)


def soft(world, env, floor):
    _ground(world, env, floor)
    block = world.create_entity(env=env, name="block")
    block.add(cressim.Transform(position=(0.1, 0, 0.1)))
    block.add(cressim.Collider(cressim.Shape.box((0.15, 0.15, 0.1))))
    block.add(cressim.Renderable(world.add_mesh(cressim.Mesh.box((0.15, 0.15, 0.1))), color=(0.3, 0.35, 0.45, 1)))
    cube = world.create_entity(env=env, name="tissue")
    cube.add(cressim.Transform(position=(0, 0, 0.5), rotation=(0.2, 0.1, 0, 1)))
    cube.add(cressim.SoftBody(cressim.TetMesh.box((0.1, 0.1, 0.1), (5, 5, 5)), mass=0.01, radius=0.02,
                              distance_compliance=0.05, volume_compliance=1e-3, damping=0.5))


def fluid(world, env, floor):
    r = 0.025
    half = 0.2
    walls = [cressim.Shape.plane()]
    for sx, sy, hx, hy in ((1, 0, 0.05, half + 0.1), (-1, 0, 0.05, half + 0.1), (0, 1, half, 0.05), (0, -1, half, 0.05)):
        walls.append(cressim.Shape.box((hx, hy, 0.3), position=(sx * (half + 0.05), sy * (half + 0.05), 0.3)))
    box = world.create_entity(env=env, name="box")
    box.add(cressim.Transform())
    box.add(cressim.Collider(walls))
    box.add(cressim.Renderable(floor[0], texture=floor[1], roughness=0.8))  # the floor; the walls are not drawn
    water = world.create_entity(env=env, name="water")
    water.add(cressim.Transform())
    water.add(cressim.Fluid(_lattice((4, 8, 12), 2 * r, (-half + r, -half + r, r)), radius=r, viscosity=0.01,
                            cohesion=0.05, surface_tension=0.05, vorticity=0.01))


def thread(world, env, floor):
    holder = world.create_entity(env=env, name="needle_holder")
    holder.add(cressim.Transform(position=(0, 0, 0.5)))
    holder.add(cressim.RigidBody(kinematic=True))
    holder.add(cressim.Collider(cressim.Shape.capsule(0.005, 0.05)))
    _ground(world, env, floor)
    n = 40
    points = np.stack([np.zeros(n), np.zeros(n), 0.5 - 0.01 * np.arange(n)], 1)
    strand = world.create_entity(env=env, name="thread")
    strand.add(cressim.Strand(points, mass=0.0005, radius=0.004, bend_compliance=1.0, damping=0.5))
    return holder


SCENES = {"soft": soft, "fluid": fluid, "thread": thread}


def run(name: str, frames: int = 120, out_dir: str = "out/demo", num_envs: int = 1, images: int = 4,
        width: int = 160, height: int = 120) -> int:
    world = cressim.World(cressim.SceneLayout(num_envs))
    floor = (world.add_mesh(cressim.Mesh.plane(1.0)), world.add_texture(io.checker_texture()))
    handles = [SCENES[name](world, env, floor) for env in range(num_envs)]
    for env in range(num_envs):
        _camera_and_light(world, env, name, width, height)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    shots = set(np.linspace(0, frames - 1, images).astype(int).tolist()) if images else set()
    engine = cressim.Engine(world)
    engine.physics = cressim.PhysicsSettings(substeps=4, particle_iterations=8)
    engine.prepare()
    engine.upload_world()
    mapping = engine.particle_mapping
    if name == "thread":  # the thread's first particle hangs from the holder, which then swings
        for env, holder in enumerate(handles):
            engine.attach_particle(env=env, slot=0, particle=int(mapping["env_offset"][env]), body=holder)
    pos, vel = [], []
    for f in range(frames):
        if name == "thread":
            for holder in handles:
                holder.transform = cressim.Transform(position=(0.2 * math.sin(f / 20), 0, 0.5))
        engine.step_physics()
        engine.end_frame()
        pos.append(engine.buffer("particles.positions").read()[:, :3].copy())
        vel.append(engine.buffer("particles.velocities").read()[:, :3].copy())
        if f in shots:
            engine.step_visual_sensors()
            engine.end_frame()
            io.save_png(out / f"{name}_{f:03d}_rgb.png", engine.buffer("camera0.rgb").read()[0, ..., :3])
            io.save_png(out / f"{name}_{f:03d}_segmentation.png",
                        io.colour_segmentation(engine.buffer("camera0.segmentation").read()[0]))
    path = out / f"{name}.npz"
    np.savez_compressed(path, positions=np.array(pos), velocities=np.array(vel), surface=mapping["surface"],
                        object_offset=mapping["object_offset"], object_count=mapping["object_count"],
                        object_kind=mapping["object_kind"], object_env=mapping["object_env"],
                        dt=engine.physics.dt)
    p = pos[-1]
    print(f"{name}: {p.shape[0]} particles, {frames} frames; last frame z in [{p[:, 2].min():.3f}, "
          f"{p[:, 2].max():.3f}], health events {engine.health_events}; wrote {path} and {2 * len(shots)} images")
    return 0
