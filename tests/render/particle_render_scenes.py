"""Small scenes for the particle drawing tests: a camera at y = -1 looking along +y (x right,
z up in the image), soft bodies, fluids and strands in front of it."""
import math

import numpy as np

import cressim
from physics.particle_scenes import lattice, start  # noqa: F401  (shared with the physics tests)

S = 64
FOV = 50
F = 0.5 * S / math.tan(math.radians(FOV / 2))  # focal length in pixels
EYE = np.array([0.0, -1.0, 0.1])
LOOK_ALONG_Y = (-math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5))  # camera z -> world +y, camera y -> world -z


def project(points):
    """Pixel (u, v) and depth of world points in the test camera."""
    rel = np.asarray(points, float) - EYE
    x, y, z = rel[..., 0], -rel[..., 2], rel[..., 1]
    return np.stack([F * x / z + S / 2, F * y / z + S / 2], -1), z


def world_with_camera(envs=1, width=S, height=S, ground=True, products=("rgb", "depth", "segmentation")):
    world = cressim.World(cressim.SceneLayout(envs))
    for env in range(envs):
        cam = world.create_entity(env=env, name="camera")
        cam.add(cressim.Transform(position=tuple(EYE), rotation=LOOK_ALONG_Y))
        cam.add(cressim.Camera(width=width, height=height, fov_y=FOV, products=list(products)))
        if ground:
            g = world.create_entity(env=env, name="ground")
            g.add(cressim.Transform())
            g.add(cressim.Collider(cressim.Shape.plane()))
    return world


def soft_cube(world, env=0, centre=(0, 0, 0.1), half=0.1, cells=2, **material):
    cube = world.create_entity(env=env, name="cube")
    cube.add(cressim.Transform(position=centre))
    cube.add(cressim.SoftBody(cressim.TetMesh.box((half, half, half), (cells, cells, cells)), radius=0.02,
                              distance_compliance=1e-3, volume_compliance=0.0, damping=1.0))
    if material:
        cube.add(cressim.Material(**material))
    return cube


def fluid_block(world, env=0, counts=(6, 3, 3), r=0.02, origin=(-0.1, -0.05, 0.02), budget=0):
    water = world.create_entity(env=env, name="fluid")
    water.add(cressim.Fluid(lattice(counts, 2 * r, origin), budget=budget, radius=r))
    return water




def render(engine, physics_frames=0):
    for _ in range(physics_frames):
        engine.step_physics()
        engine.end_frame()
    engine.step_visual_sensors()
    engine.end_frame()
    return (engine.buffer("camera0.rgb").read().copy(), engine.buffer("camera0.depth").read().copy(),
            engine.buffer("camera0.segmentation").read().copy())
