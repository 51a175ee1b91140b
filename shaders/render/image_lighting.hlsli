// The ambient term of an env with an environment map (render/environment_map.h): diffuse from
// the map's SH9 irradiance, specular from the prefiltered levels (the map itself at roughness
// 0), weighted by the split-sum environment BRDF in Lazarov's analytic fit (2013).
// Needs raster_resources.hlsli.
#include "environment_map.hlsli"

float3 ibl_diffuse(uint slot, float3 n) {  // radiance off a white Lambertian surface
  float y[9];
  sh9_basis(n, y);
  float3 e = 0;
  for (uint k = 0; k < IBL_SH; ++k) e += ibl_sh[slot * IBL_SH + k].rgb * y[k];
  return max(e, 0);
}

float3 ibl_level_texel(uint first, int2 p) {
  p = int2(((p.x % int(IBL_SPEC_W)) + int(IBL_SPEC_W)) % int(IBL_SPEC_W), clamp(p.y, 0, int(IBL_SPEC_H) - 1));
  return ibl_specular[first + uint(p.y) * IBL_SPEC_W + uint(p.x)].rgb;
}

float3 ibl_level(uint slot, uint level, float3 d) {  // bilinear
  const uint first = (slot * IBL_LEVELS + level) * IBL_SPEC_W * IBL_SPEC_H;
  const float2 x = equirect_uv(d) * float2(IBL_SPEC_W, IBL_SPEC_H) - 0.5;
  const int2 p = int2(floor(x));
  const float2 f = x - float2(p);
  return lerp(lerp(ibl_level_texel(first, p), ibl_level_texel(first, p + int2(1, 0)), f.x),
              lerp(ibl_level_texel(first, p + int2(0, 1)), ibl_level_texel(first, p + int2(1, 1)), f.x), f.y);
}

float3 ibl_reflected(EnvLighting env, float3 r, float roughness) {  // prefiltered radiance along r
  const float x = roughness * IBL_LEVELS;  // 0: the map, k + 1: level k
  const uint k = min(uint(floor(x)), IBL_LEVELS - 1);
  const float3 lo = k == 0 ? sample_map(env.map.x - 1, r) * env.map_scale.rgb : ibl_level(env.map.y, k - 1, r);
  return lerp(lo, ibl_level(env.map.y, k, r), saturate(x - float(k)));
}

float3 image_lighting(EnvLighting env, float3 n, float3 v, float3 base, float metallic, float roughness) {
  const float nv = saturate(dot(n, v));
  const float4 r = roughness * float4(-1, -0.0275, -0.572, 0.022) + float4(1, 0.0425, 1.04, -0.04);
  const float a004 = min(r.x * r.x, exp2(-9.28 * nv)) * r.x + r.y;
  const float2 ab = float2(-1.04, 1.04) * a004 + r.zw;
  const float3 f0 = lerp(float3(0.04, 0.04, 0.04), base, metallic);
  const float3 specular = saturate(f0 * ab.x + ab.y);
  return (1 - specular) * (1 - metallic) * base * ibl_diffuse(env.map.y, n) +
         specular * ibl_reflected(env, reflect(-v, n), roughness);
}
