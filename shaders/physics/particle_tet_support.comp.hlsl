// Substep end, one workgroup per elastic body: how much of the substep's fall under gravity its
// solve held back, as a fraction (0: falling freely, 1: fully supported by fixed particles,
// contacts or grasps), mass-weighted over its free particles from x - prev - h v (v still the
// substep's predicted velocity). The next substep's solve starts that much of the fall short of
// the inertial position (particle_integrate.comp.hlsl). Measured per particle instead, the
// support of a solve cut short fed back into the next start and a 20 kPa column crept 3 times
// too far. It also adds the substep's contact forces of the elastic solve on kinematic bodies
// (particle_tet.comp.hlsl) to the frame's rigid_forces.
#include "cressim/layout.h"
#include "cressim/particle.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<ParticleObject> objects;
StructuredBuffer<uint4> phases;
StructuredBuffer<float4> positions;
StructuredBuffer<float4> prev_positions;
StructuredBuffer<float4> velocities;
StructuredBuffer<float4> tet_contact_forces;
RWStructuredBuffer<float> object_supports;
RWStructuredBuffer<float4> rigid_forces;

groupshared float2 sums[CRESSIM_GROUP_SIZE];

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 group : SV_GroupID, uint3 thread : SV_GroupThreadID) {
  const uint o = group.x, lane = thread.x;
  const uint first = objects[o].range.x, count = objects[o].range.y;
  if (count == 0 || (phases[first].w & PARTICLE_ELASTIC) == 0) return;  // uniform in the group
  // the fall integrate applied this substep, along g: h^2 |g| / drag (times |g| to dot with g)
  const float h = pc.gravity.w, fall = h * h * dot(pc.gravity.xyz, pc.gravity.xyz) / (1 + h * objects[o].material.z);
  float2 s = float2(0, 0);  // sum of m (held-back fall, in units of that fall), sum of m
  for (uint i = first + lane; i < first + count; i += CRESSIM_GROUP_SIZE) {
    const float4 x = positions[i];
    if (x.w <= 0 || (phases[i].w & PARTICLE_ACTIVE) == 0) continue;
    const float4 on_body = tet_contact_forces[i];
    if (on_body.w > 0) rigid_forces[i] = float4(rigid_forces[i].xyz + on_body.xyz / pc.grid.w, on_body.w);
    const float3 c = x.xyz - prev_positions[i].xyz - h * velocities[i].xyz;
    s += float2(fall > 0 ? -dot(c, pc.gravity.xyz) / fall : 0, 1) / x.w;
  }
  sums[lane] = s;
  GroupMemoryBarrierWithGroupSync();
  for (uint k = CRESSIM_GROUP_SIZE / 2; k > 0; k >>= 1) {
    if (lane < k) sums[lane] += sums[lane + k];
    GroupMemoryBarrierWithGroupSync();
  }
  if (lane == 0) object_supports[o] = sums[0].y > 0 ? saturate(sums[0].x / sums[0].y) : 0;
}
