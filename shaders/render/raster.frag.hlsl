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
  SurfacePoint p;
  p.world = i.world;
  p.dp_dx = ddx(i.world);
  p.dp_dy = ddy(i.world);
  // meshes whose vertices come from a buffer have no normals: the triangle's, from derivatives
  p.normal = (r.maps.y & RENDER_FLAT_NORMALS) != 0 ? cross(p.dp_dy, p.dp_dx) : i.normal;
  p.uv = i.uv;
  p.burn = i.burn;
  p.uv_grad = float4(ddx(i.uv), ddy(i.uv));
  PSOut o;
  o.color = encode_color(shade(r, p, positions[cameras[i.camera].ids.x].xyz));
  o.depth = i.depth;
  o.segmentation = r.ids.z;
  return o;
}
