// Screen-space fluid, pass 1: every active fluid particle, as a sphere impostor, into the
// cameras of its env in this group: the nearest sphere depth per pixel (atomic min) and the
// thickness of fluid in front of the scene (atomic add of each ray's chord through a sphere).
// One thread per particle slot; inactive slots draw nothing.
#include "cressim/particle.h"
#include "cressim/quat.h"
#include "cressim/render.h"

#include "fluid_screen.hlsli"

[[vk::binding(0)]] StructuredBuffer<float4> particle_positions;
[[vk::binding(1)]] StructuredBuffer<uint4> particle_phases;
[[vk::binding(2)]] StructuredBuffer<ParticleObject> particle_objects;
[[vk::binding(3)]] StructuredBuffer<CameraData> cameras;
[[vk::binding(4)]] StructuredBuffer<float4> positions;  // transform.* rows
[[vk::binding(5)]] StructuredBuffer<float4> rotations;
[[vk::binding(6)]] StructuredBuffer<uint2> env_layers;   // per env: first entry in layer_cameras, count
[[vk::binding(7)]] StructuredBuffer<uint> layer_cameras;  // camera ids of this group, env by env
[[vk::binding(8)]] StructuredBuffer<float> scene_depth;   // (layers, H, W), 0: nothing
[[vk::binding(9)]] RWStructuredBuffer<uint> fluid_depth;
[[vk::binding(10)]] RWStructuredBuffer<uint> fluid_thickness;

[[vk::push_constant]] ConstantBuffer<FluidParams> pc;

static const int MAX_SPAN = 128;  // pixels a side of one impostor (a nearer particle is skipped)

[numthreads(64, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint i = id.x;
  if (i >= pc.particle_count) return;
  const uint4 phase = particle_phases[i];
  if (phase.x != PARTICLE_FLUID || (phase.w & PARTICLE_ACTIVE) == 0) return;
  const float3 x = particle_positions[i].xyz;
  const float radius = FLUID_DRAW_SCALE * particle_objects[phase.y].material.x;
  const uint2 list = env_layers[phase.z];
  for (uint k = list.x; k < list.x + list.y; ++k) {
    const CameraData c = cameras[layer_cameras[k]];
    const uint eye = c.ids.x, layer = c.ids.w;
    const float3 X = quat_unrotate(rotations[eye], x - positions[eye].xyz);  // camera frame
    if (X.z - radius < c.clip.x || X.z - radius > c.clip.y) continue;
    const float2 centre = c.intrinsics.xy * X.xy / X.z + c.intrinsics.zw;
    const float2 extent = c.intrinsics.xy * radius / (X.z - radius);  // bounds the projected disc
    const int2 lo = max(int2(floor(centre - extent)), 0), hi = min(int2(ceil(centre + extent)), int2(pc.width, pc.height) - 1);
    if (any(hi - lo > MAX_SPAN)) continue;
    for (int v = lo.y; v <= hi.y; ++v)
      for (int u = lo.x; u <= hi.x; ++u) {
        // the ray t d (d.z = 1: t is depth) against the sphere
        const float3 d = float3((float2(u, v) + 0.5 - c.intrinsics.zw) / c.intrinsics.xy, 1);
        const float dd = dot(d, d), dx = dot(d, X);
        const float disc = dx * dx - dd * (dot(X, X) - radius * radius);
        if (disc <= 0) continue;
        const float root = sqrt(disc), front = (dx - root) / dd;
        if (front < c.clip.x) continue;
        const uint at = (layer * pc.height + uint(v)) * pc.width + uint(u);
        const float behind = scene_depth[at];
        if (behind > 0 && front >= behind) continue;
        uint previous;
        InterlockedMin(fluid_depth[at], asuint(front), previous);
        const float back = behind > 0 ? min((dx + root) / dd, behind) : (dx + root) / dd;
        const float chord = (back - front) * sqrt(dd);
        InterlockedAdd(fluid_thickness[at], uint(chord / FLUID_THICKNESS_UNIT), previous);
      }
  }
}
