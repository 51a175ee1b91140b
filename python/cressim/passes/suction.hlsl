// Suction, a thread per particle: where an env's suction is on, its active fluid particles within
// `radius` of the tip are flagged for removal (control.particle_remove, applied at the next
// step's start) and counted. The tip is a point in a rigid body (a suction tube's end) or, with
// no body, in the world.
// suctions (int4 per env): x on (1) / off (0), y the rigid body (-1: none), z unused, w removed so
//   far (counted here).
// suction_tips (float4 per env): xyz the tip in the body's frame (the world's without a body),
//   w the radius (m).
#include "cressim/layout.h"
#include "cressim/particle.h"
#include "cressim/quat.h"

struct Params { uint count; uint pad0; uint pad1; uint pad2; };
[[vk::push_constant]] ConstantBuffer<Params> pc;
StructuredBuffer<float4> positions;
StructuredBuffer<uint4> phases;
StructuredBuffer<float4> body_positions;
StructuredBuffer<float4> body_rotations;
StructuredBuffer<float4> suction_tips;
RWStructuredBuffer<int4> suctions;
RWStructuredBuffer<uint> remove;

[numthreads(64, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint i = id.x;
  if (i >= pc.count) return;
  const uint4 ph = phases[i];
  if (ph.x != PARTICLE_FLUID || (ph.w & PARTICLE_ACTIVE) == 0 || remove[i] != 0) return;
  const int4 s = suctions[ph.z];
  if (s.x == 0) return;
  const float4 tip = suction_tips[ph.z];
  float3 at = tip.xyz;
  if (s.y >= 0) at = body_positions[s.y].xyz + quat_rotate(body_rotations[s.y], tip.xyz);
  if (length(positions[i].xyz - at) >= tip.w) return;
  remove[i] = 1;
  InterlockedAdd(suctions[ph.z].w, 1);
}
