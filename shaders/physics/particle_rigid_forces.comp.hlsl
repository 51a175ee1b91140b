// At the end of the particle step, one thread per env: each body's particle contact forces
// (summed per particle by particle_gather) are added to the body's contact force and torque,
// which the rigid step wrote for its own contacts this frame.
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

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint env = id.x;
  if (env >= pc.env_count || pc.has_rigid == 0) return;
  const uint4 pr = env_ranges[env].range;
  const uint4 br = env_rigid_ranges[env].bodies;
  for (uint b = br.x; b < br.x + br.y; ++b) {
    float3 f = float3(0, 0, 0), t = float3(0, 0, 0);
    for (uint i = pr.x; i < pr.x + pr.y; ++i) {
      const float4 fi = rigid_forces[i];
      if (uint(fi.w) != b + 1) continue;
      f += fi.xyz;
      t += cross(rigid_contacts[i].xyz - body_positions[b].xyz, fi.xyz);
    }
    body_contact_forces[b].xyz += f;
    body_contact_torques[b].xyz += t;
  }
}
