// Shading (Lambert + Blinn-Phong from the env's directional light and an ambient term),
// metric depth along the optical axis, and the segmentation id.
#include "cressim/quat.h"
#include "cressim/render.h"

#include "raster_resources.hlsli"

struct PSOut {
  float4 color : SV_Target0;
  float depth : SV_Target1;
  uint segmentation : SV_Target2;
};

PSOut main(Varyings i) {
  const RenderableData r = renderables[i.renderable];
  const CameraData c = cameras[i.camera];
  const EnvLight light = lights[r.ids.w];
  float3 n = normalize(i.normal);
  const float3 to_eye = normalize(positions[c.ids.x].xyz - i.world);
  if (dot(n, to_eye) < 0) n = -n;  // two-sided
  const float3 l = -normalize(light.direction.xyz);
  const float diffuse = saturate(dot(n, l));
  const float shininess = 2.0 / max(r.material.y * r.material.y, 1e-3);
  const float specular = diffuse > 0 ? pow(saturate(dot(n, normalize(l + to_eye))), shininess) : 0;
  const float3 base = r.color.rgb;
  const float3 f0 = lerp(float3(0.04, 0.04, 0.04), base, r.material.x);
  const float3 rgb = base * (1 - r.material.x) * (light.direction.w + diffuse * light.color.rgb) +
                     f0 * specular * light.color.rgb;
  PSOut o;
  o.color = float4(pow(saturate(rgb), 1.0 / 2.2), r.color.a);  // to sRGB-ish 8-bit
  o.depth = i.depth;
  o.segmentation = r.ids.z;
  return o;
}
