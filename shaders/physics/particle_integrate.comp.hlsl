// Substep start: remember the positions, then move every active, finite-mass particle by its
// velocity after gravity and its object's damping.
#include "cressim/layout.h"
#include "cressim/particle.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<ParticleObject> objects;
StructuredBuffer<uint4> phases;
RWStructuredBuffer<float4> positions;
RWStructuredBuffer<float4> velocities;
RWStructuredBuffer<float4> prev_positions;

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint i = id.x;
  if (i >= pc.particle_count) return;
  const float4 x = positions[i];
  prev_positions[i] = x;
  const uint4 ph = phases[i];
  if ((ph.w & PARTICLE_ACTIVE) == 0 || x.w <= 0) return;
  const float h = pc.gravity.w;
  float3 v = velocities[i].xyz + h * pc.gravity.xyz;
  v /= 1 + h * objects[ph.y].material.z;
  velocities[i].xyz = v;
  positions[i].xyz = x.xyz + h * v;
}
