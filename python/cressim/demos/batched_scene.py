"""The foundation demo: a batched scene, a user compute pass over it, a checked summary.

Each env holds a ring of markers; every frame a custom HLSL pass turns them about the env's
axis by an angle read from a shared buffer and writes each env's centroid and spread.
The result is checked against numpy and written to `out_dir/summary.json`.
"""
from __future__ import annotations

import json
import math
import time
from pathlib import Path

import numpy as np

import cressim

MARKERS = 8

ORBIT = """
#include "cressim/layout.h"
struct Params { uint envs; float step; };
[[vk::push_constant]] ConstantBuffer<Params> pc;
StructuredBuffer<float4> positions;      // the authored markers (internal, read-only)
StructuredBuffer<uint> env_offset;       // layout mapping: first row of each env
StructuredBuffer<uint> env_count;        //                 rows of each env
RWStructuredBuffer<float> angle;         // per env, advanced every frame
RWStructuredBuffer<float4> stats;        // per env: centroid xyz, mean radius

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint env = id.x;
  if (env >= pc.envs) return;
  const float a = angle[env] + pc.step * (1.0 + env % 8);
  angle[env] = a;
  const float c = cos(a), s = sin(a);
  float3 sum = 0;
  float radius = 0;
  const uint first = env_offset[env], n = env_count[env];
  for (uint r = first; r < first + n; ++r) {
    const float3 p = positions[r].xyz;
    const float3 q = float3(c * p.x - s * p.y, s * p.x + c * p.y, p.z);
    sum += q;
    radius += length(q.xy);
  }
  stats[env] = n > 0 ? float4(sum / n, radius / n) : 0;
}
"""


def build_world(num_envs: int) -> cressim.World:
    world = cressim.World(cressim.SceneLayout(num_envs))
    for env in range(num_envs):
        for k in range(MARKERS):
            phi = 2 * math.pi * k / MARKERS
            r = 0.05 * (1 + env % 4)
            world.create_entity(env=env, name=f"marker{k}").add(
                cressim.Transform(position=(r * math.cos(phi) + 0.01 * env, r * math.sin(phi), 0.1)))
    return world


def run(num_envs: int = 16, frames: int = 120, out_dir: str = "out/demo") -> int:
    world = build_world(num_envs)
    engine = cressim.Engine(world)
    engine.prepare()
    engine.upload_world()
    angle = engine.create_shared_buffer("angle", num_envs)
    stats = engine.create_shared_buffer("stats", (num_envs, 4))
    step = 3.0 / (8 * frames)  # keeps every angle within pi, where GPU sin/cos are accurate
    orbit = engine.create_compute_pass(
        ORBIT, name="orbit", threads=num_envs, constants={"envs": num_envs, "step": step},
        bindings={"positions": "transform.positions", "env_offset": "env.entity_offset",
                  "env_count": "env.entity_count", "angle": angle, "stats": stats})
    engine.profiling = True
    start = time.perf_counter()
    for _ in range(frames):
        engine.step_physics()
        engine.execute_compute_pass(orbit)
        engine.end_frame()
    wall = time.perf_counter() - start

    # the same arithmetic in numpy, from the layout mapping
    pos = engine.buffer("transform.positions").read()[:, :3].astype(np.float64)
    m = engine.mapping
    a = np.zeros(num_envs, np.float32)  # accumulated in float32, as the shader does
    for _ in range(frames):
        a += np.float32(step) * (1 + np.arange(num_envs) % 8).astype(np.float32)
    expected = np.zeros((num_envs, 4))
    for env in range(num_envs):
        p = pos[m["env_offset"][env]: m["env_offset"][env] + m["env_count"][env]]
        q = np.stack([np.cos(a[env]) * p[:, 0] - np.sin(a[env]) * p[:, 1],
                      np.sin(a[env]) * p[:, 0] + np.cos(a[env]) * p[:, 1], p[:, 2]], 1)
        expected[env] = [*q.mean(0), np.linalg.norm(q[:, :2], axis=1).mean()]
    error = float(np.abs(stats.read() - expected).max())

    summary = {
        "device": engine.device["name"], "envs": num_envs, "entities": world.entity_count, "frames": frames,
        "recorded_frames": engine.recorded_frames, "submits": engine.submits,
        "frames_per_s": frames / wall, "gpu_ms_per_stage": dict(engine.last_timings),
        "max_abs_error_vs_numpy": error,
    }
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    print(f"cressim demo on {summary['device']}: {num_envs} envs x {MARKERS} markers, {frames} frames, "
          f"{summary['recorded_frames']} recording(s), {summary['submits']} submits, "
          f"{summary['frames_per_s']:.0f} frames/s")
    for label, ms in engine.last_timings:
        print(f"  {label:28s} {ms * 1000:9.1f} us")
    print(f"  max |GPU - numpy| = {error:.2e}; summary in {out / 'summary.json'}")
    return 0 if error < 1e-4 else 1
