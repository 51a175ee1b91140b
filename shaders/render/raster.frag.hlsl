// The fragment stage: shading (shading.hlsli), metric depth along the optical axis, the
// segmentation id.
#include "cressim/quat.h"
#include "cressim/render.h"

#include "raster_resources.hlsli"
#include "shading.hlsli"

struct PSOut {
  float4 color : SV_Target0;
  float depth : SV_Target1;
  uint segmentation : SV_Target2;
};

PSOut main(Varyings i) {
  const RenderableData r = renderables[i.renderable];
  // meshes whose vertices come from a buffer have no normals: the triangle's, from derivatives
  const float3 n = r.maps.y != 0 ? cross(ddy(i.world), ddx(i.world)) : i.normal;
  PSOut o;
  o.color = encode_color(shade(r, i.world, n, i.uv, float4(ddx(i.uv), ddy(i.uv)), positions[cameras[i.camera].ids.x].xyz));
  o.depth = i.depth;
  o.segmentation = r.ids.z;
  return o;
}
