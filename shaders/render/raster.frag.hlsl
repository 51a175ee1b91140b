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
  PSOut o;
  o.color = encode_color(shade(r, i.world, i.normal, i.uv, positions[cameras[i.camera].ids.x].xyz));
  o.depth = i.depth;
  o.segmentation = r.ids.z;
  return o;
}
