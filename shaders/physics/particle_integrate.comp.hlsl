// Substep start: remember the positions, then move every active, finite-mass particle by its
// velocity after gravity and its object's damping (an elastic particle by its velocity before
// gravity: the solve adds the load).
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
  const float h = pc.gravity.w, drag = 1 + h * objects[ph.y].material.z;
  const float3 v0 = velocities[i].xyz, v = (v0 + h * pc.gravity.xyz) / drag;
  velocities[i].xyz = v;
  // an elastic particle's solve starts from where its velocity alone takes it (at rest: where it
  // is), not from the inertial target x + h v with gravity: a solve cut short then stops at the
  // static equilibrium, not short of it by the load of one substep (particle_tet.comp.hlsl)
  positions[i].xyz = x.xyz + h * ((ph.w & PARTICLE_ELASTIC) != 0 ? v0 / drag : v);
}
