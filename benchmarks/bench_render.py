"""Rendering throughput: N envs, each a ground plane, a lit cube and a sphere seen by one camera;
frames rendered per second (one step_visual_sensors per frame, synchronised every frame) at
several resolutions. Usage: python benchmarks/bench_render.py --envs 256,1024,4096 --sizes 64,128,256
A/B switches: --sphere-rings (tessellation: the first part's numbers used 24 rings x 48
segments = 2,304 triangles; 6 gives 144), --shadows (a 256^2 shadow map per env from the sun),
--point-lights N (extra point lights per env), --products rgb (what cameras write),
--raster graphics|compute|both (CRESSIM_RASTER: graphics pipelines or the compute rasterizer),
--objects N (N more small boxes per env, scattered over 20 x 20 m: most outside the camera's
view) with --culling on|off|both (CRESSIM_CULLING: frustum culling of the graphics path's draw
list; the compute rasterizer tests each tile either way, so there only the counts change),
--ibl (image-based lighting from a 256 x 128 environment map instead of the hemisphere)."""
from __future__ import annotations

import argparse
import json
import math
import os
import time

import numpy as np

import cressim


def build(envs: int, size: int, rings: int = 24, shadows: bool = False, point_lights: int = 0,
          products=("rgb", "depth", "segmentation"), objects: int = 0, ibl: bool = False) -> cressim.Engine:
    world = cressim.World(cressim.SceneLayout(envs, max_lights_per_env=1 + point_lights,
                                              max_renderables_per_env=max(16, 3 + objects)))
    cube, ball, plane = (world.add_mesh(cressim.Mesh.box((0.1, 0.1, 0.1))),
                         world.add_mesh(cressim.Mesh.sphere(0.08, rings, 2 * rings)), world.add_mesh(cressim.Mesh.plane(2.0)))
    if ibl:  # a sky gradient over a brown ground with a bright sun
        rows = np.linspace(0, 1, 128)[:, None, None]
        sky = np.where(rows < 0.5, 255 * (0.4 + 0.5 * rows) * np.array([0.5, 0.7, 1.0]), [110, 80, 50])
        sky = np.broadcast_to(sky, (128, 256, 3)).copy()
        sky[20:24, 60:64] = 255
        env_map = world.add_texture(cressim.Texture(np.dstack([sky, np.full((128, 256), 255)]).astype(np.uint8)))
    for env in range(envs):
        if ibl:
            world.create_entity(env=env, name="environment").add(cressim.EnvironmentLight(map=env_map, intensity=1.2))
        for mesh, pos, color in ((plane, (0, 0, 0), (0.5, 0.5, 0.5, 1)), (cube, (0.2 * math.sin(env), 0, 0.1), (0.9, 0.2, 0.1, 1)),
                                 (ball, (-0.2, 0.1, 0.08), (0.1, 0.3, 0.9, 1))):
            e = world.create_entity(env=env)
            e.add(cressim.Transform(position=pos))
            e.add(cressim.Renderable(mesh, color=color))
        for k in range(objects):  # a fixed scatter (golden-angle spiral), the same in every env
            radius, angle = 10 * math.sqrt((k + 0.5) / objects), k * 2.39996
            e = world.create_entity(env=env)
            e.add(cressim.Transform(position=(radius * math.cos(angle), radius * math.sin(angle), 0.05)))
            e.add(cressim.Renderable(cube, color=(0.2, 0.7, 0.3, 1)))
        sun = world.create_entity(env=env, name="sun")
        sun.add(cressim.Transform(position=(0, 0, 1), rotation=(0.2, 0.1, 0.0, 0.97)))
        sun.add(cressim.Light(shadows=shadows, shadow_extent=1.0))
        for k in range(point_lights):
            lamp = world.create_entity(env=env, name=f"lamp{k}")
            lamp.add(cressim.Transform(position=(0.3 * k - 0.3, -0.4, 0.5)))
            lamp.add(cressim.Light(kind="point", intensity=0.2))
        cam = world.create_entity(env=env, name="camera")
        # looking along +y, tilted 30 deg down (optical z forward, y down)
        cam.add(cressim.Transform(position=(0, -1.0, 0.5), rotation=(-math.sin(math.pi / 3), 0, 0, math.cos(math.pi / 3))))
        cam.add(cressim.Camera(width=size, height=size, fov_y=50, products=list(products)))
    engine = cressim.Engine(world)
    engine.prepare()
    engine.upload_world()
    return engine


def measure(raster: str, size: int, envs: int, args, culling: str = "on") -> dict:
    os.environ["CRESSIM_RASTER"] = raster  # both read when the renderer is built (upload_world)
    os.environ["CRESSIM_CULLING"] = "1" if culling == "on" else "0"
    engine = build(envs, size, args.sphere_rings, args.shadows, args.point_lights, args.products.split(","),
                   args.objects, args.ibl)
    for _ in range(10):
        engine.step_visual_sensors()
        engine.end_frame()
    engine.profiling = True
    t = time.perf_counter()
    for _ in range(args.frames):
        engine.step_visual_sensors()
        engine.end_frame()
    dt = (time.perf_counter() - t) / args.frames
    gpu_ms = sum(ms for _, ms in engine.last_timings)
    mem = sum(engine.buffer(k).nbytes for k in engine.internal_keys if k.startswith("camera")) / envs
    visible, culled = engine.buffer("render.visible_counts").read().sum(0).tolist()
    print(f"{raster:8s} culling {culling:3s} {visible / envs:6.1f} drawn {culled / envs:6.1f} culled per camera, "
          f"{size:4d}x{size:<4d} {envs:6d} envs: {envs / dt:12,.0f} images/s ({1 / dt:7.1f} frames/s, "
          f"GPU {gpu_ms:6.2f} ms/frame, outputs {mem / 1024:.1f} KiB/camera)", flush=True)
    return {"raster": raster, "size": size, "envs": envs, "frames_per_s": 1 / dt, "camera_images_per_s": envs / dt,
            "gpu_ms_per_frame": gpu_ms, "output_bytes_per_camera": mem, "device": engine.device["name"],
            "sphere_rings": args.sphere_rings, "shadows": args.shadows, "point_lights": args.point_lights,
            "products": args.products, "objects": args.objects, "culling": culling,
            "ibl": args.ibl, "visible_per_camera": visible / envs, "culled_per_camera": culled / envs}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--envs", default="64,256,1024,4096")
    ap.add_argument("--sizes", default="64,128,256")
    ap.add_argument("--frames", type=int, default=100)
    ap.add_argument("--sphere-rings", type=int, default=24, help="sphere tessellation (rings; segments = 2x)")
    ap.add_argument("--shadows", action="store_true", help="the sun casts shadows (a shadow map per env)")
    ap.add_argument("--point-lights", type=int, default=0, help="point lights per env besides the sun")
    ap.add_argument("--raster", default="both", choices=("graphics", "compute", "both"))
    ap.add_argument("--products", default="rgb,depth,segmentation", help="what each camera writes, e.g. rgb")
    ap.add_argument("--objects", type=int, default=0, help="more small boxes per env, scattered over 20 x 20 m")
    ap.add_argument("--culling", default="on", choices=("on", "off", "both"), help="CRESSIM_CULLING")
    ap.add_argument("--ibl", action="store_true", help="image-based lighting from an environment map")
    ap.add_argument("--json")
    args = ap.parse_args()
    rasters = ("graphics", "compute") if args.raster == "both" else (args.raster,)
    cullings = ("on", "off") if args.culling == "both" else (args.culling,)
    rows = [measure(raster, size, envs, args, culling) for raster in rasters for culling in cullings
            for size in map(int, args.sizes.split(",")) for envs in map(int, args.envs.split(","))]
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=2)


if __name__ == "__main__":
    main()
