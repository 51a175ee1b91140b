// After each gather, one thread per env: the dynamic bodies take their share of this
// iteration's particle contacts (particle_gather), as a position and rotation change and the
// matching change of velocity over the frame (two-way coupling). A body's contacts add up (each
// was split as if it were the only one; averaging them instead let a resting box sink through).
#include "cressim/layout.h"
#include "cressim/particle.h"
#include "cressim/quat.h"
#include "cressim/rigid.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<ParticleEnvRange> env_ranges;
StructuredBuffer<EnvRigidRange> env_rigid_ranges;
StructuredBuffer<BodyModel> bodies;
StructuredBuffer<float4> rigid_pushes;
StructuredBuffer<float4> rigid_contacts;
RWStructuredBuffer<float4> body_positions;
RWStructuredBuffer<float4> body_rotations;
RWStructuredBuffer<float4> body_linear_velocities;
RWStructuredBuffer<float4> body_angular_velocities;

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint env = id.x;
  if (env >= pc.env_count || pc.has_rigid == 0) return;
  const uint4 pr = env_ranges[env].range;
  const uint4 br = env_rigid_ranges[env].bodies;
  const float frame = pc.gravity.w * pc.grid.w;
  for (uint b = br.x; b < br.x + br.y; ++b) {
    const BodyModel m = bodies[b];
    if (m.inv_inertia.w <= 0) continue;
    float3 p = float3(0, 0, 0), l = float3(0, 0, 0);
    for (uint i = pr.x; i < pr.x + pr.y; ++i) {
      const float4 push = rigid_pushes[i];
      if (uint(push.w) != b + 1) continue;
      p += push.xyz;
      l += cross(rigid_contacts[i].xyz - body_positions[b].xyz, push.xyz);
    }
    if (dot(p, p) == 0) continue;
    const float4 q = body_rotations[b];
    const float3 dx = -m.inv_inertia.w * p;
    const float3 dw = -quat_rotate(q, m.inv_inertia.xyz * quat_unrotate(q, l));
    body_positions[b].xyz += dx;
    body_rotations[b] = quat_add_rotation(q, dw);
    body_linear_velocities[b].xyz += dx / frame;
    body_angular_velocities[b].xyz += dw / frame;
  }
}
