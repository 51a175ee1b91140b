// Every (renderable, camera of its env) pair is one instance; each writes its camera's layer
// of the group's layered targets, so all envs' cameras render in one pass.
#include "cressim/quat.h"
#include "cressim/render.h"

#include "raster_resources.hlsli"

// the layer is an output of its own: the fragment stage may not read it (it would need Geometry)
Varyings main(uint mesh_vertex : SV_VertexID, uint instance : SV_InstanceID, out uint layer : SV_RenderTargetArrayIndex) {
  const uint2 pair = instances[instance];
  const RenderableData r = renderables[pair.x];
  const CameraData c = cameras[pair.y];
  const uint vertex = mesh_vertex + r.maps.z;
  const uint eye = c.ids.x;
  const float3 world = world_position(r, vertex);
  const float3 local = quat_unrotate(rotations[eye], world - positions[eye].xyz);
  const float near = c.clip.x, far = c.clip.y;
  Varyings o;
  // clip space of a pinhole with the given intrinsics; Vulkan's y points down like the image's
  const float2 pixel = c.intrinsics.xy * local.xy + c.intrinsics.zw * local.z;  // (u, v) * z
  o.position = float4(2.0 * pixel / c.clip.zw - local.z, far * (local.z - near) / (far - near), local.z);
  o.world = world;
  o.normal = world_normal(r, vertex);
  o.uv = vertex_uvs[vertex];
  o.burn = world_burn(r, vertex);
  o.depth = local.z;
  o.renderable = pair.x;
  o.camera = pair.y;
  layer = c.ids.w;
  return o;
}
