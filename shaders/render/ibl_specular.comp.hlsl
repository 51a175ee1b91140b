// Image-based lighting, step 3: specular prefiltering. Each texel of a level's small
// equirectangular map is the slot's grid radiance weighted by the GGX lobe of that level's
// roughness around the texel's direction r, with normal = view = r (the split-sum
// approximation of Karis 2013): weight D(h) (r.l) / (4 r.h) per solid angle, normalised, so a
// uniform map stays uniform. One thread per (texel, level, slot).
#include "cressim/render.h"

[[vk::binding(0)]] StructuredBuffer<float4> ibl_grid;
[[vk::binding(1)]] RWStructuredBuffer<float4> ibl_specular;

#include "ibl_math.hlsli"

[numthreads(64, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint texel = id.x, level = id.y, slot = id.z;
  if (texel >= IBL_SPEC_W * IBL_SPEC_H) return;
  const float3 r = equirect_direction((float2(texel % IBL_SPEC_W, texel / IBL_SPEC_W) + 0.5) /
                                      float2(IBL_SPEC_W, IBL_SPEC_H));
  const float roughness = float(level + 1) / IBL_LEVELS, a = roughness * roughness, a2 = a * a;
  const uint cells = IBL_GRID_W * IBL_GRID_H;
  const float d_theta = IBL_PI / IBL_GRID_H, d_phi = 2 * IBL_PI / IBL_GRID_W;
  float3 sum = 0;
  float weights = 0;
  for (uint i = 0; i < cells; ++i) {
    const float2 uv = (float2(i % IBL_GRID_W, i / IBL_GRID_W) + 0.5) / float2(IBL_GRID_W, IBL_GRID_H);
    const float3 l = equirect_direction(uv);
    const float rl = dot(r, l);
    if (rl <= 0) continue;
    const float rh = dot(r, normalize(r + l));
    const float d = a2 / (IBL_PI * pow(rh * rh * (a2 - 1) + 1, 2));
    const float w = d * rl / (4 * rh) * sin(uv.y * IBL_PI) * d_theta * d_phi;
    sum += w * ibl_grid[slot * cells + i].rgb;
    weights += w;
  }
  ibl_specular[((slot * IBL_LEVELS + level) * IBL_SPEC_H) * IBL_SPEC_W + texel] = float4(sum / max(weights, 1e-20), 0);
}
