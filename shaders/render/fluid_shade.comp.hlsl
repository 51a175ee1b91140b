// Screen-space fluid, pass 3: where the smoothed fluid surface is in front of the scene, its
// normal from the smoothed depths (per axis the neighbour with the smaller step, so silhouettes
// do not bend it), the env's lights on it (shading.hlsli, the fluid's Material), the scene
// behind seen through it with Beer-Lambert absorption by the thickness (the colour is what 2 cm
// shows over white), a Schlick Fresnel mix towards the sky; composited into the group's colour,
// depth and segmentation.
#include "cressim/quat.h"
#include "cressim/render.h"

#include "raster_resources.hlsli"
#include "shading.hlsli"
#include "fluid_screen.hlsli"

[[vk::binding(15)]] StructuredBuffer<uint> group_cameras;
[[vk::binding(16)]] StructuredBuffer<RenderableData> fluid_looks;
[[vk::binding(17)]] StructuredBuffer<uint> fluid_smoothed;  // float bits, FLUID_NONE: no fluid
[[vk::binding(18)]] StructuredBuffer<uint> fluid_smoothed_thickness;
[[vk::binding(19)]] RWStructuredBuffer<float> scene_depth;  // the group's depth (or a stand-in)
[[vk::binding(20)]] RWStructuredBuffer<uint> out_rgb;
[[vk::binding(21)]] RWStructuredBuffer<uint> out_segmentation;

struct ShadeParams {
  uint width;
  uint height;
  uint layers;
  uint products;  // CameraProduct bits this group writes
};
[[vk::push_constant]] ConstantBuffer<ShadeParams> pc;

static const float REFERENCE_THICKNESS = 0.02;  // m: the Material colour is the look through this much

float3 camera_point(CameraData c, int2 px, float z) {
  return float3((float2(px) + 0.5 - c.intrinsics.zw) / c.intrinsics.xy, 1) * z;
}

// the step towards the neighbour on the flatter side along one axis (0 when neither has fluid)
float3 flatter_step(CameraData c, uint plane, int2 px, int2 axis, float3 here) {
  float3 best = 0;
  float best_dz = 1e30;
  for (int s = -1; s <= 1; s += 2) {
    const int2 q = px + s * axis;
    if (any(q < 0) || q.x >= int(pc.width) || q.y >= int(pc.height)) continue;
    const uint bits = fluid_smoothed[plane + uint(q.y) * pc.width + uint(q.x)];
    const float z = asfloat(bits);
    if (bits == FLUID_NONE || abs(z - here.z) >= best_dz) continue;
    best_dz = abs(z - here.z);
    best = float(s) * (camera_point(c, q, z) - here);
  }
  return best;
}

[numthreads(8, 8, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint layer = id.z;
  if (id.x >= pc.width || id.y >= pc.height) return;
  const uint plane = layer * pc.height * pc.width, at = plane + id.y * pc.width + id.x;
  const uint bits = fluid_smoothed[at];
  const float z = asfloat(bits), behind = scene_depth[at];
  if (bits == FLUID_NONE || (behind > 0 && z >= behind)) return;
  const CameraData c = cameras[group_cameras[layer]];
  const RenderableData look = fluid_looks[c.ids.y];
  const int2 px = int2(id.xy);
  const float3 here = camera_point(c, px, z);
  const float3 du = flatter_step(c, plane, px, int2(1, 0), here), dv = flatter_step(c, plane, px, int2(0, 1), here);
  float3 n = cross(dv, du);  // camera frame (x right, y down, z ahead): faces the eye
  n = dot(n, n) > 0 ? normalize(n) : float3(0, 0, -1);
  if (n.z > 0) n = -n;
  const float4 eye_q = rotations[c.ids.x];
  const float3 eye = positions[c.ids.x].xyz, world = eye + quat_rotate(eye_q, here);
  const float3 wn = quat_rotate(eye_q, n);
  if (pc.products & 1) {
    const float thickness = float(fluid_smoothed_thickness[at]) * FLUID_THICKNESS_UNIT;
    const float3 transmit = pow(max(look.color.rgb, 1e-3), thickness / REFERENCE_THICKNESS);
    const uint w = out_rgb[at];
    const float3 scene = pow(float3(w & 0xff, (w >> 8) & 0xff, (w >> 16) & 0xff) / 255.0, 2.2);
    // light scattered inside: the fluid's colour lit like a surface, where the scene is hidden
    const SurfacePoint p = {world, wn, float2(0, 0), float4(0, 0, 0, 0), float3(0, 0, 0), float3(0, 0, 0)};
    const float3 lit = shade(look, p, eye).rgb;
    float3 rgb = scene * transmit + lit * (1 - transmit);
    const float cos_v = saturate(-dot(n, normalize(here)));
    const float fresnel = 0.02 + 0.98 * pow(1 - cos_v, 5);
    const EnvLighting env = env_lighting[c.ids.y];
    rgb = lerp(rgb, env.sky.rgb, fresnel);
    const uint4 bytes = uint4(round(saturate(encode_color(float4(rgb, 1))) * 255));
    out_rgb[at] = bytes.x | (bytes.y << 8) | (bytes.z << 16) | (bytes.w << 24);
  }
  if (pc.products & 2) scene_depth[at] = z;
  if (pc.products & 4) out_segmentation[at] = look.ids.z;
}
