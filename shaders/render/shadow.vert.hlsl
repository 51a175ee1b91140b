// Shadow maps: every (renderable, env with a shadowed light) pair is one instance, drawn with
// an orthographic projection along the light into its env's layer.
#include "cressim/quat.h"
#include "cressim/render.h"

#include "raster_resources.hlsli"

float4 main(uint vertex : SV_VertexID, uint instance : SV_InstanceID, out uint layer : SV_RenderTargetArrayIndex)
    : SV_Position {
  const uint2 pair = shadow_instances[instance];
  const RenderableData r = renderables[pair.x];
  const EnvLighting env = env_lighting[r.ids.w];
  const float3 p = shadow_frame(env, world_position(r, vertex + r.maps.z));
  layer = pair.y;
  return float4(p.xy / env.shadow.x, (p.z + env.shadow.y) / (2 * env.shadow.y), 1);
}
