// Screen-space fluid, pass 2: a bilateral filter of the sphere depths (a Gaussian over a
// window about one impostor radius on screen, neighbours weighted down by their depth
// difference in units of the particle radius), which turns the bumps of separate spheres
// into one surface; pixels without fluid stay without.
#include "cressim/render.h"

#include "fluid_screen.hlsli"

[[vk::binding(0)]] StructuredBuffer<CameraData> cameras;
[[vk::binding(1)]] StructuredBuffer<uint> group_cameras;  // this group's camera per layer
[[vk::binding(2)]] StructuredBuffer<RenderableData> fluid_looks;  // per env; material.z particle radius
[[vk::binding(3)]] StructuredBuffer<uint> fluid_depth;
[[vk::binding(4)]] RWStructuredBuffer<float> fluid_smoothed;  // 0: no fluid

[[vk::push_constant]] ConstantBuffer<FluidParams> pc;

static const int MAX_RADIUS = 6;  // pixels

[numthreads(8, 8, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint layer = id.z;
  if (id.x >= pc.width || id.y >= pc.height) return;
  const uint plane = layer * pc.height * pc.width, at = plane + id.y * pc.width + id.x;
  const uint bits = fluid_depth[at];
  if (bits == FLUID_NONE) {
    fluid_smoothed[at] = 0;
    return;
  }
  const float z = asfloat(bits);
  const CameraData c = cameras[group_cameras[layer]];
  const float radius = FLUID_DRAW_SCALE * fluid_looks[c.ids.y].material.z;
  const float sigma = max(c.intrinsics.x * radius / z, 0.5);  // pixels
  const int reach = min(int(ceil(1.5 * sigma)), MAX_RADIUS);
  float sum = 0, weight = 0;
  for (int dy = -reach; dy <= reach; ++dy)
    for (int dx = -reach; dx <= reach; ++dx) {
      const int2 q = int2(id.xy) + int2(dx, dy);
      if (any(q < 0) || q.x >= int(pc.width) || q.y >= int(pc.height)) continue;
      const uint b = fluid_depth[plane + uint(q.y) * pc.width + uint(q.x)];
      if (b == FLUID_NONE) continue;
      const float zq = asfloat(b), dz = (zq - z) / radius;
      const float w = exp(-float(dx * dx + dy * dy) / (2 * sigma * sigma) - dz * dz);
      sum += w * zq;
      weight += w;
    }
  fluid_smoothed[at] = sum / weight;
}
