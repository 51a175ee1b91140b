// Cautery, a thread per env: each env's heat source (control.heat_sources) is placed at its tool's
// energized tip (a point in a rigid body, or in the world with no body), with its radius and, while
// the env's cautery is on, its power (0 while off) and mode. The engine's heat passes put that
// power into the tissue within the radius (particle_heat_flow.comp.hlsl); in cut mode the tissue
// it has coagulated there is cut (particle_tet_coagulate.comp.hlsl).
// cauteries (int4 per env): x on (1) / off (0), y the rigid body (-1: none), z cut mode (1) /
//   coagulation (0), w unused.
// cautery_tips (float4 per env): xyz the tip in the body's frame (the world's without a body), w the
//   radius (m). cautery_powers (float per env): W while on; a task pass may write it.
#include "cressim/layout.h"
#include "cressim/quat.h"

struct Params { uint envs; uint pad0; uint pad1; uint pad2; };
[[vk::push_constant]] ConstantBuffer<Params> pc;
StructuredBuffer<float4> body_positions;
StructuredBuffer<float4> body_rotations;
StructuredBuffer<float4> cautery_tips;
StructuredBuffer<float> cautery_powers;
StructuredBuffer<int4> cauteries;
RWStructuredBuffer<float4> sources;

[numthreads(64, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint env = id.x;
  if (env >= pc.envs) return;
  const int4 c = cauteries[env];
  const float4 tip = cautery_tips[env];
  const float3 at = c.y >= 0 ? body_positions[c.y].xyz + quat_rotate(body_rotations[c.y], tip.xyz) : tip.xyz;
  sources[2 * env] = float4(at, tip.w);
  sources[2 * env + 1] = float4(c.x != 0 ? cautery_powers[env] : 0, c.z != 0 ? 1 : 0, 0, 0);
}
