// Equirectangular environment maps read from the world's textures (RGBA8 sRGB texels). Needs
// `texels` and `texture_infos` declared before it.
#include "ibl_math.hlsli"

float3 map_texel(TextureInfo t, int2 p) {  // linear; wraps in azimuth, clamps at the poles
  const int2 size = int2(t.extent.yz);
  p = int2(((p.x % size.x) + size.x) % size.x, clamp(p.y, 0, size.y - 1));
  const uint w = texels[t.extent.x + uint(p.y) * t.extent.y + uint(p.x)];
  return pow(float3(w & 0xff, (w >> 8) & 0xff, (w >> 16) & 0xff) / 255.0, 2.2);
}

float3 sample_map(uint index, float3 d) {  // texture index; bilinear
  const TextureInfo t = texture_infos[index];
  const float2 x = equirect_uv(d) * float2(t.extent.yz) - 0.5;
  const int2 p = int2(floor(x));
  const float2 f = x - float2(p);
  return lerp(lerp(map_texel(t, p), map_texel(t, p + int2(1, 0)), f.x),
              lerp(map_texel(t, p + int2(0, 1)), map_texel(t, p + int2(1, 1)), f.x), f.y);
}
