// Substep end: velocities from the positions' change.
#include "cressim/layout.h"
#include "cressim/particle.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<uint4> phases;
StructuredBuffer<float4> positions;
StructuredBuffer<float4> prev_positions;
RWStructuredBuffer<float4> velocities;

#include "particle_substep_velocity.hlsli"

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint i = id.x;
  if (i >= pc.particle_count || (phases[i].w & PARTICLE_ACTIVE) == 0) return;
  velocities[i].xyz = substep_velocity(positions[i].xyz, prev_positions[i].xyz);
}
