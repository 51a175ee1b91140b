// Suction, a thread per particle (and at least one per env): where an env's suction is on, its
// active fluid particles within `radius` of the tip are flagged for removal
// (control.particle_remove, applied at the next step's start) and counted, and the env's fluid
// sink (control.fluid_sinks) is placed at the tip, so the next step draws the fluid within
// `reach` toward it at the flow rate (particle_integrate.comp.hlsl). The tip is a point in a
// rigid body (a suction tube's end) or, with no body, in the world.
// suctions (int4 per env): x on (1) / off (0), y the rigid body (-1: none), z unused, w removed so
//   far (counted here).
// suction_tips (float4 per env): xyz the tip in the body's frame (the world's without a body),
//   w the radius (m).
// suction_flows (float4 per env): x the flow rate (m^3/s; a task pass may write it), y the reach (m).
#include "cressim/layout.h"
#include "cressim/particle.h"
#include "cressim/quat.h"

struct Params { uint count; uint envs; uint pad1; uint pad2; };
[[vk::push_constant]] ConstantBuffer<Params> pc;
StructuredBuffer<float4> positions;
StructuredBuffer<uint4> phases;
StructuredBuffer<float4> body_positions;
StructuredBuffer<float4> body_rotations;
StructuredBuffer<float4> suction_tips;
StructuredBuffer<float4> suction_flows;
RWStructuredBuffer<int4> suctions;
RWStructuredBuffer<uint> remove;
RWStructuredBuffer<float4> sinks;

float3 tip_of(uint env, int4 s) {
  const float3 tip = suction_tips[env].xyz;
  return s.y >= 0 ? body_positions[s.y].xyz + quat_rotate(body_rotations[s.y], tip) : tip;
}

[numthreads(64, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint i = id.x;
  if (i < pc.envs) {
    const int4 s = suctions[i];
    const float4 flow = suction_flows[i];
    sinks[2 * i] = float4(tip_of(i, s), s.x != 0 ? flow.y : 0);
    sinks[2 * i + 1] = float4(flow.x, suction_tips[i].w, 0, 0);
  }
  if (i >= pc.count) return;
  const uint4 ph = phases[i];
  if (ph.x != PARTICLE_FLUID || (ph.w & PARTICLE_ACTIVE) == 0 || remove[i] != 0) return;
  const int4 s = suctions[ph.z];
  if (s.x == 0) return;
  if (length(positions[i].xyz - tip_of(ph.z, s)) >= suction_tips[ph.z].w) return;
  remove[i] = 1;
  InterlockedAdd(suctions[ph.z].w, 1);
}
