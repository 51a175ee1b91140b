// Screen-space fluid, pass 2 (run twice: along rows, then along columns): a separable bilateral
// filter of the sphere depths, a Gaussian of sigma twice the impostor radius on screen (about
// the particle spacing), neighbours weighted down by their depth difference in units of the
// particle diameter plus their screen offset at that depth (so a surface seen obliquely is
// smoothed across its slope too). It turns the bumps of separate spheres into one surface;
// pixels without fluid stay without. The thickness gets the same Gaussian without the depth
// weight (the sum of sphere chords is spotty where spheres meet).
#include "cressim/render.h"

#include "fluid_screen.hlsli"

[[vk::binding(0)]] StructuredBuffer<CameraData> cameras;
[[vk::binding(1)]] StructuredBuffer<uint> group_cameras;          // this group's camera per layer
[[vk::binding(2)]] StructuredBuffer<RenderableData> fluid_looks;  // per env; material.z particle radius
[[vk::binding(3)]] StructuredBuffer<uint> depth_in;               // float bits, FLUID_NONE: no fluid
[[vk::binding(4)]] StructuredBuffer<uint> thickness_in;           // FLUID_THICKNESS_UNIT counts
[[vk::binding(5)]] RWStructuredBuffer<uint> depth_out;
[[vk::binding(6)]] RWStructuredBuffer<uint> thickness_out;

struct SmoothParams {
  uint width;
  uint height;
  uint layers;
  uint axis;  // 0: along rows, 1: along columns
};
[[vk::push_constant]] ConstantBuffer<SmoothParams> pc;

static const int MAX_REACH = 32;  // pixels

[numthreads(8, 8, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint layer = id.z;
  if (id.x >= pc.width || id.y >= pc.height) return;
  const uint plane = layer * pc.height * pc.width, at = plane + id.y * pc.width + id.x;
  const CameraData c = cameras[group_cameras[layer]];
  const float radius = FLUID_DRAW_SCALE * fluid_looks[c.ids.y].material.z;
  const uint bits = depth_in[at];
  const bool fluid = bits != FLUID_NONE;
  const float z = asfloat(bits);
  // pixels without fluid carry the thickness on; their window is the one at a typical depth
  const float sigma = max(2 * c.intrinsics.x * radius / (fluid ? z : 1.0), 0.5);
  const int reach = min(int(ceil(2 * sigma)), MAX_REACH);
  const int2 step = pc.axis == 0 ? int2(1, 0) : int2(0, 1);
  const int limit = pc.axis == 0 ? int(pc.width) : int(pc.height), here = pc.axis == 0 ? int(id.x) : int(id.y);
  float sum = 0, weight = 0, thickness = 0, spatial = 0;
  for (int k = max(-reach, -here); k <= min(reach, limit - 1 - here); ++k) {
    const int2 q = int2(id.xy) + k * step;
    const uint near = plane + uint(q.y) * pc.width + uint(q.x);
    const float g = exp(-float(k * k) / (2 * sigma * sigma));
    thickness += g * float(thickness_in[near]);
    spatial += g;
    const uint b = depth_in[near];
    if (!fluid || b == FLUID_NONE) continue;
    const float tolerance = 2 * radius + abs(float(k)) * z / c.intrinsics.x;
    const float zq = asfloat(b), dz = (zq - z) / tolerance;
    const float w = g * exp(-dz * dz);
    sum += w * zq;
    weight += w;
  }
  depth_out[at] = fluid ? asuint(sum / weight) : FLUID_NONE;
  thickness_out[at] = uint(round(thickness / spatial));
}
