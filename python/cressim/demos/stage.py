"""A demo scene's camera and its sun: the camera at `eye` looking at `target`, a shadowing
directional light at `sun` shining toward `sun_target`."""
from __future__ import annotations

import cressim
from cressim.scene_file import _quat_look_at


def add_camera_and_sun(world, env: int, *, eye, target, sun, sun_target, width: int, height: int,
                       fov_y: float = 45.0, intensity: float = 2.5, shadow_extent: float = 0.1,
                       shadow_resolution: int = 512):
    cam = world.create_entity(env=env, name="camera")
    cam.add(cressim.Transform(position=eye, rotation=_quat_look_at(eye, target)))
    cam.add(cressim.Camera(width=width, height=height, fov_y=fov_y))
    light = world.create_entity(env=env, name="sun")
    light.add(cressim.Transform(position=sun, rotation=_quat_look_at(sun, sun_target)))
    light.add(cressim.Light(intensity=intensity, shadows=True, shadow_extent=shadow_extent,
                            shadow_resolution=shadow_resolution))
