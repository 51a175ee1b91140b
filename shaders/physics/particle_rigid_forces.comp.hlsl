// At the end of the particle step, one thread group per env: each body's particle contact forces
// (summed per particle by particle_gather) are added to the body's contact force and torque,
// which the rigid step wrote for its own contacts this frame. Body after body, the group's
// threads stride over the env's particles and sum in group memory.
#include "cressim/layout.h"
#include "cressim/particle.h"
#include "cressim/rigid.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<ParticleEnvRange> env_ranges;
StructuredBuffer<EnvRigidRange> env_rigid_ranges;
StructuredBuffer<float4> body_positions;
StructuredBuffer<float4> rigid_forces;
StructuredBuffer<float4> rigid_contacts;
RWStructuredBuffer<float4> body_contact_forces;
RWStructuredBuffer<float4> body_contact_torques;

groupshared float3 group_force[PARTICLE_ENV_GROUP];
groupshared float3 group_torque[PARTICLE_ENV_GROUP];

[numthreads(PARTICLE_ENV_GROUP, 1, 1)]
void main(uint3 group : SV_GroupID, uint lane : SV_GroupIndex) {
  const uint env = group.x;
  if (env >= pc.env_count || pc.has_rigid == 0) return;  // the whole group
  const uint4 pr = env_ranges[env].range;
  const uint4 br = env_rigid_ranges[env].bodies;
  for (uint b = br.x; b < br.x + br.y; ++b) {
    const float3 origin = body_positions[b].xyz;
    float3 f = float3(0, 0, 0), t = float3(0, 0, 0);
    for (uint i = pr.x + lane; i < pr.x + pr.y; i += PARTICLE_ENV_GROUP) {
      const float4 fi = rigid_forces[i];
      if (uint(fi.w) != b + 1) continue;
      f += fi.xyz;
      t += cross(rigid_contacts[i].xyz - origin, fi.xyz);
    }
    group_force[lane] = f;
    group_torque[lane] = t;
    GroupMemoryBarrierWithGroupSync();
    for (uint half_ = PARTICLE_ENV_GROUP / 2; half_ > 0; half_ /= 2) {
      if (lane < half_) {
        group_force[lane] += group_force[lane + half_];
        group_torque[lane] += group_torque[lane + half_];
      }
      GroupMemoryBarrierWithGroupSync();
    }
    if (lane == 0) {
      body_contact_forces[b].xyz += group_force[0];
      body_contact_torques[b].xyz += group_torque[0];
    }
    GroupMemoryBarrierWithGroupSync();  // the sums are read before the next body's overwrite them
  }
}
