// Shading shared by the fragment stage and the compute rasterizer: GGX / Cook-Torrance
// specular and Lambert diffuse from each of the env's lights (directional, point, spot;
// shadows from the env's shadowed directional light), an ambient term (a hemisphere, or the
// env's environment map: image_lighting.hlsli), base colour times an optional texture. Needs
// raster_resources.hlsli.
#include "image_lighting.hlsli"

static const float PI = 3.14159265;
static const uint MAX_MIP_LEVELS = 16;  // textures up to 32,768 texels a side

float4 texel(uint first, int2 size, int2 p) {
  p = ((p % size) + size) % size;  // wrap
  const uint w = texels[first + uint(p.y) * uint(size.x) + uint(p.x)];
  return float4(w & 0xff, (w >> 8) & 0xff, (w >> 16) & 0xff, w >> 24) / 255.0;
}

float4 bilinear(TextureInfo t, uint level, float2 uv) {
  uint first = t.extent.x;
  uint2 size = t.extent.yz;
  // levels follow one another, each half the one above; a fixed bound: looping up to `level`
  // alone read the wrong level in lavapipe's compute rasterizer (its graphics path was right)
  for (uint k = 0; k < MAX_MIP_LEVELS - 1; ++k) {
    if (k >= level) break;
    first += size.x * size.y;
    size = max(size / 2, 1);
  }
  const float2 x = uv * float2(size) - 0.5;
  const int2 p = int2(floor(x)), s = int2(size);
  const float2 f = x - float2(p);
  return lerp(lerp(texel(first, s, p), texel(first, s, p + int2(1, 0)), f.x),
              lerp(texel(first, s, p + int2(0, 1)), texel(first, s, p + int2(1, 1)), f.x), f.y);
}

// A surface point as the rasterizers see it: changes per pixel (x right, y down) pick texture
// levels and orient normal maps.
struct SurfacePoint {
  float3 world;
  float3 normal;   // need not be unit length or face the eye
  float2 uv;
  float4 uv_grad;  // (du/dx, dv/dx, du/dy, dv/dy)
  float3 dp_dx, dp_dy;  // world position
  float burn;      // share of the tissue coagulated: its colour turns to COAGULATED
};

// coagulated soft tissue turns a pale grey-tan (linear RGB)
static const float3 COAGULATED = float3(0.36, 0.28, 0.2);

// trilinear, the stored values (sRGB-encoded for colours); uv_grad picks the level whose
// texels are about a pixel wide (the larger of the two screen axes)
float4 sample_texels(uint index, float2 uv, float4 uv_grad) {
  const TextureInfo t = texture_infos[index];
  const float2 size = float2(t.extent.yz);
  const float texels_per_pixel = max(length(uv_grad.xy * size), length(uv_grad.zw * size));
  const uint last = clamp(t.extent.w, 1u, MAX_MIP_LEVELS) - 1;
  const float lod = clamp(log2(max(texels_per_pixel, 1e-8)), 0.0, float(last));
  const uint k = uint(lod);
  float4 c = bilinear(t, k, uv);
  if (k < last && lod > k) c = lerp(c, bilinear(t, k + 1, uv), lod - k);
  return c;
}

// a colour texture: sRGB texels to linear
float4 sample_texture(uint index, float2 uv, float4 uv_grad) {
  const float4 c = sample_texels(index, uv, uv_grad);
  return float4(pow(c.rgb, 2.2), c.a);
}

// the unit normal n (facing the eye) tilted by the tangent-space normal map: x along +u, y
// toward the image's top (-v: rows grow with v), z along n. The frame comes from how position
// and uv change across the pixel (no stored tangents): t and b are the surface gradients of u
// and v (t . dp_dx = du/dx, ...) times the determinant, whose sign is taken back out (screen y
// runs down here, so it is negative where the surface faces the eye), and scaled together.
float3 apply_normal_map(RenderableData r, SurfacePoint p, float3 n) {
  float3 m = sample_texels((r.maps.y >> RENDER_NORMAL_MAP_SHIFT) - 1, p.uv, p.uv_grad).xyz * 2 - 1;
  m.xy *= r.material.w;
  const float3 across_y = cross(p.dp_dy, n), across_x = cross(n, p.dp_dx);
  const float3 t = across_y * p.uv_grad.x + across_x * p.uv_grad.z;
  const float3 b = across_y * p.uv_grad.y + across_x * p.uv_grad.w;
  const float scale = max(dot(t, t), dot(b, b));
  if (!(scale > 1e-30)) return n;  // no uv change across the pixel: nothing to orient the map by
  const float orientation = dot(p.dp_dx, across_y) < 0 ? -1.0 : 1.0;
  const float3 tilted = (t * m.x - b * m.y) * (orientation * rsqrt(scale)) + n * m.z;
  return dot(tilted, tilted) > 0 ? normalize(tilted) : n;
}

// fraction of a 3x3 texel neighbourhood that sees the light (1 outside the map)
float shadow_factor(EnvLighting env, float3 world, float3 n) {
  const float S = env.shadow.z, half_size = env.shadow.x, range = env.shadow.y;
  const float texel_size = 2 * half_size / S;
  const float3 p = shadow_frame(env, world + 1.5 * texel_size * n);  // normal offset against acne
  const float2 uv = (p.xy / half_size * 0.5 + 0.5) * S;
  if (any(uv < 0) || any(uv >= S)) return 1;
  const float z = (p.z + range) / (2 * range) - texel_size / (2 * range);
  const uint first = (env.ids.z - 1) * uint(S) * uint(S);
  const int2 centre = int2(uv);
  float lit = 0;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) {
      const int2 t = clamp(centre + int2(dx, dy), 0, int(S) - 1);
      lit += z <= shadow_maps[first + uint(t.y) * uint(S) + uint(t.x)] ? 1.0 : 0.0;
    }
  return lit / 9;
}

// outgoing radiance per unit incoming (x pi: a white matte surface facing a light of 1 shows 1)
float3 brdf_cos(float3 n, float3 v, float3 l, float3 base, float metallic, float roughness) {
  const float nl = saturate(dot(n, l));
  if (nl <= 0) return 0;
  const float nv = max(dot(n, v), 1e-4);
  const float3 h = normalize(l + v);
  const float a = roughness * roughness, a2 = a * a;
  const float nh = saturate(dot(n, h));
  const float d = a2 / (PI * pow(nh * nh * (a2 - 1) + 1, 2));
  const float k = (roughness + 1) * (roughness + 1) / 8;
  const float g = nl / (nl * (1 - k) + k) * nv / (nv * (1 - k) + k);
  const float3 f0 = lerp(float3(0.04, 0.04, 0.04), base, metallic);
  const float3 f = f0 + (1 - f0) * pow(1 - saturate(dot(h, v)), 5);
  const float3 diffuse = (1 - f) * (1 - metallic) * base;
  return (diffuse + PI * d * g * f / (4 * nl * nv)) * nl;
}

// linear RGBA of a surface point seen from `eye`
float4 shade(RenderableData r, SurfacePoint p, float3 eye) {
  const EnvLighting env = env_lighting[r.ids.w];
  const float3 world = p.world;
  float3 n = normalize(p.normal);
  const float3 v = normalize(eye - world);
  if (dot(n, v) < 0) n = -n;  // two-sided
  if ((r.maps.y >> RENDER_NORMAL_MAP_SHIFT) != 0) n = apply_normal_map(r, p, n);
  float4 base = r.color;
  if (r.maps.x != 0) base *= sample_texture(r.maps.x - 1, p.uv, p.uv_grad);
  base.rgb = lerp(base.rgb, COAGULATED, saturate(p.burn));
  const float metallic = saturate(r.material.x), roughness = clamp(r.material.y, 0.05, 1.0);
  float3 rgb = env.map.x != 0 ? image_lighting(env, n, v, base.rgb, metallic, roughness)
                              : lerp(env.ground.rgb, env.sky.rgb, 0.5 + 0.5 * n.z) * base.rgb;
  for (uint k = 0; k < env.ids.y; ++k) {
    const LightData light = lights[env.ids.x + k];
    const uint kind = light.ids.y, row = light.ids.x;
    if (kind == 0) continue;
    const float3 axis = row == RENDER_NO_ROW ? normalize(light.direction.xyz) : quat_rotate(rotations[row], float3(0, 0, 1));
    float3 l = -axis, radiance = light.color.rgb;
    if (kind == LIGHT_DIRECTIONAL) {
      if (env.ids.z != 0 && row == env.ids.w) radiance *= shadow_factor(env, world, n);
    } else {
      const float3 to_light = positions[row].xyz - world;
      const float d2 = max(dot(to_light, to_light), 1e-8);
      l = to_light * rsqrt(d2);
      radiance /= d2;
      const float range = light.color.w;
      if (range > 0) radiance *= pow(saturate(1 - pow(d2 / (range * range), 2)), 2);  // smooth cut-off
      if (kind == LIGHT_SPOT) radiance *= smoothstep(light.cone.y, light.cone.x, dot(-l, axis));
    }
    rgb += brdf_cos(n, v, l, base.rgb, metallic, roughness) * radiance;
  }
  return float4(rgb, base.a);
}

// to sRGB-ish 8-bit
float4 encode_color(float4 linear_rgba) { return float4(pow(saturate(linear_rgba.rgb), 1.0 / 2.2), linear_rgba.a); }
