// The rasterizer's buffers, bound at the same numbers in every stage (each stage alone would
// number them by its own use), what the vertex stage hands the fragment stage, and the vertex
// transform that the camera and shadow passes share.
[[vk::binding(0)]] StructuredBuffer<float4> vertex_positions;
[[vk::binding(1)]] StructuredBuffer<float4> vertex_normals;
[[vk::binding(2)]] StructuredBuffer<uint2> instances;  // x renderable, y camera
[[vk::binding(3)]] StructuredBuffer<RenderableData> renderables;
[[vk::binding(4)]] StructuredBuffer<CameraData> cameras;
[[vk::binding(5)]] StructuredBuffer<LightData> lights;
[[vk::binding(6)]] StructuredBuffer<float4> positions;  // transform.* rows
[[vk::binding(7)]] StructuredBuffer<float4> rotations;
[[vk::binding(8)]] StructuredBuffer<float4> scales;
[[vk::binding(9)]] StructuredBuffer<float2> vertex_uvs;
[[vk::binding(10)]] StructuredBuffer<EnvLighting> env_lighting;
[[vk::binding(11)]] StructuredBuffer<TextureInfo> texture_infos;
[[vk::binding(12)]] StructuredBuffer<uint> texels;  // RGBA8
[[vk::binding(13)]] StructuredBuffer<float> shadow_maps;  // (maps, S, S), normalised light depth
[[vk::binding(14)]] StructuredBuffer<uint2> shadow_instances;  // x renderable, y layer
// image-based lighting (render/environment_map.h), per slot; apart from the rest's numbers
[[vk::binding(40)]] StructuredBuffer<float4> ibl_sh;        // (slots, 9): diffuse SH9
[[vk::binding(41)]] StructuredBuffer<float4> ibl_specular;  // (slots, levels, H, W) prefiltered radiance

struct Varyings {
  float4 position : SV_Position;
  float3 world : POSITION1;
  float3 normal : NORMAL;
  float2 uv : TEXCOORD0;
  float burn : BURN;    // share of the tissue coagulated (world_burn)
  float depth : DEPTH;  // along the optical axis
  nointerpolation uint renderable : RENDERABLE;
  nointerpolation uint camera : CAMERA;
};

// `vertex` includes the renderable's own offset (maps.z)
float3 world_position(RenderableData r, uint vertex) {
  if (r.maps.w & RENDER_WORLD_VERTICES) return vertex_positions[vertex].xyz;
  const uint row = r.ids.x;
  return positions[row].xyz + quat_rotate(rotations[row], scales[row].xyz * vertex_positions[vertex].xyz);
}

// particle surfaces carry their particle's coagulated share in the normal's w
// (particle_vertices.comp.hlsl); other meshes none
float world_burn(RenderableData r, uint vertex) {
  return (r.maps.w & RENDER_WORLD_VERTICES) ? vertex_normals[vertex].w : 0;
}

float3 world_normal(RenderableData r, uint vertex) {
  if (r.maps.w & RENDER_WORLD_VERTICES) return vertex_normals[vertex].xyz;
  const uint row = r.ids.x;
  return quat_rotate(rotations[row], vertex_normals[vertex].xyz / scales[row].xyz);
}

// A point in the frame of an env's shadow light: xy across the map, z along the light.
float3 shadow_frame(EnvLighting env, float3 world) {
  const uint eye = env.ids.w;
  return quat_unrotate(rotations[eye], world - positions[eye].xyz);
}
