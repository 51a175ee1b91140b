"""Coagulated tissue changes colour in the cameras: the particle surface carries each particle's
thermal damage (particles.damage) and the shading turns it pale grey-tan, in both rasterizers."""
import numpy as np
import pytest

import cressim

from .particle_render_scenes import project, render, start, world_with_camera

HALF = 0.1


@pytest.mark.parametrize("raster", ["graphics", "compute"])
def test_a_coagulated_patch_turns_pale(make_engine, raster, monkeypatch):
    """Two envs, a red elastic cube with heat facing the camera in each; env 0's particles in the
    middle of the front face start at 90 C (control.particle_reset_temperatures), so they coagulate
    within a few frames: that patch turns from red toward grey-tan in the image, the face's corners
    and env 1's cube stay red."""
    monkeypatch.setenv("CRESSIM_RASTER", raster)
    world = world_with_camera(envs=2, ground=False)
    mesh = cressim.TetMesh.box((HALF, HALF, HALF), (4, 4, 4))
    for env in range(2):
        cube = world.create_entity(env=env, name="liver")
        cube.add(cressim.Transform(position=(0, 0, 0.1)))
        cube.add(cressim.SoftBody(mesh, youngs_modulus=1e4, radius=0.01, thermal=cressim.Thermal()))
        cube.add(cressim.Material(color=(0.7, 0.12, 0.1, 1), roughness=0.6))
    engine = start(world, make_engine, gravity=(0, 0, 0))
    x = engine.buffer("particles.initial_positions").read()[:, :3].reshape(2, -1, 3)
    front = np.array([0, -HALF, 0.1])
    hot = np.linalg.norm(x[0] - front, axis=1) < 0.06
    start_t = engine.buffer("control.particle_reset_temperatures").read().reshape(2, -1)
    start_t[0, hot] = 363.15
    engine.buffer("control.particle_reset_temperatures").write(start_t.reshape(-1))
    engine.reset_envs([0])
    rgb, _, _ = render(engine, physics_frames=10)
    assert engine.buffer("particles.damage").read().reshape(2, -1)[0, hot].min() > 1.0
    (u, v), _ = project(front)
    (cu, cv), _ = project(front + [0.8 * HALF, 0, 0.8 * HALF])
    patch = rgb[0, int(v) - 1:int(v) + 2, int(u) - 1:int(u) + 2, :3].reshape(-1, 3).mean(0).astype(float)
    corner = rgb[0, int(cv), int(cu), :3].astype(float)
    other = rgb[1, int(v) - 1:int(v) + 2, int(u) - 1:int(u) + 2, :3].reshape(-1, 3).mean(0).astype(float)
    assert corner[0] > 2 * corner[1] and other[0] > 2 * other[1]  # still red
    assert patch[1] > 1.2 * other[1] and patch[0] / patch[1] < 0.7 * other[0] / other[1], (patch, other)  # grey-tan
