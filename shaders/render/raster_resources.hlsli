// The rasterizer's buffers, bound at the same numbers in both stages (each stage alone would
// number them by its own use), and what the vertex stage hands the fragment stage.
[[vk::binding(0)]] StructuredBuffer<float4> vertex_positions;
[[vk::binding(1)]] StructuredBuffer<float4> vertex_normals;
[[vk::binding(2)]] StructuredBuffer<uint2> instances;  // x renderable, y camera
[[vk::binding(3)]] StructuredBuffer<RenderableData> renderables;
[[vk::binding(4)]] StructuredBuffer<CameraData> cameras;
[[vk::binding(5)]] StructuredBuffer<EnvLight> lights;
[[vk::binding(6)]] StructuredBuffer<float4> positions;  // transform.* rows
[[vk::binding(7)]] StructuredBuffer<float4> rotations;
[[vk::binding(8)]] StructuredBuffer<float4> scales;

struct Varyings {
  float4 position : SV_Position;
  float3 world : POSITION1;
  float3 normal : NORMAL;
  float depth : DEPTH;  // along the optical axis
  nointerpolation uint renderable : RENDERABLE;
  nointerpolation uint camera : CAMERA;
};
