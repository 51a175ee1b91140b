// Frustum culling for the graphics rasterizer's indirect draws: one thread per (renderable,
// camera) instance. A visible instance takes a slot in its draw's range of the draw list
// (instanceCount, atomically) and copies its pair there; the draw commands then draw only
// those. Counts per camera go to render.visible_counts. Meshes whose vertices come from a
// buffer (and particle meshes) are never culled: their bounding radius is that of the mesh as
// given, not as moved.
#include "cressim/quat.h"
#include "cressim/render.h"

#include "frustum.hlsli"

[[vk::binding(0)]] StructuredBuffer<uint2> instances;  // (renderable, camera), by group then mesh
[[vk::binding(1)]] StructuredBuffer<uint> instance_draws;  // each instance's draw command
[[vk::binding(2)]] StructuredBuffer<RenderableData> renderables;
[[vk::binding(3)]] StructuredBuffer<CameraData> cameras;
[[vk::binding(4)]] StructuredBuffer<float> mesh_radii;
[[vk::binding(5)]] StructuredBuffer<float4> positions;
[[vk::binding(6)]] StructuredBuffer<float4> rotations;
[[vk::binding(7)]] StructuredBuffer<float4> scales;
[[vk::binding(8)]] RWStructuredBuffer<uint> draw_commands;  // VkDrawIndexedIndirectCommand (5 words) per draw
[[vk::binding(9)]] RWStructuredBuffer<uint2> visible_instances;
[[vk::binding(10)]] RWStructuredBuffer<uint> visible_counts;  // per camera: visible, culled

struct Params {
  uint count;    // instances
  uint enabled;  // 0: every instance is visible (CRESSIM_CULLING=0)
};
[[vk::push_constant]] ConstantBuffer<Params> pc;

[numthreads(256, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint i = id.x;
  if (i >= pc.count) return;
  const uint2 pair = instances[i];
  const RenderableData r = renderables[pair.x];
  const CameraData c = cameras[pair.y];
  bool visible = true;
  if (pc.enabled != 0 && (r.maps.y & RENDER_FLAT_NORMALS) == 0 && (r.maps.w & RENDER_WORLD_VERTICES) == 0) {
    const uint eye = c.ids.x, row = r.ids.x;
    const float3 centre = quat_unrotate(rotations[eye], positions[row].xyz - positions[eye].xyz);
    visible = sphere_in_view(c, centre, bounding_radius(mesh_radii[r.ids.y], scales[row].xyz), float2(0, 0), c.clip.zw);
  }
  uint previous;
  InterlockedAdd(visible_counts[2 * pair.y + (visible ? 0 : 1)], 1, previous);
  if (!visible) return;
  const uint d = instance_draws[i];
  uint slot;
  InterlockedAdd(draw_commands[5 * d + 1], 1, slot);
  visible_instances[draw_commands[5 * d + 4] + slot] = pair;
}
