// Frame end, one thread per env: a dynamic body bears the load of the elastic particles it holds
// rigidly (attachment slots). The elastic solve leaves a held particle where the body put it and
// reports the force left unbalanced on it (particle_tet.comp.hlsl), which the frame's substeps
// average into particles.rigid_forces (w body + 1), the force the tool is reported to feel.
// That mean acts on the body over the next frame as an external force
// does in the rigid step: a change of velocity alone, which the next frame's prediction carries
// (the drives and contacts then answer it). Moving the body as well counted the load twice in
// steady state (a tool on a slider drive sagged by twice the weight it held). Explicit in the
// load: stable while dt^2 (tissue stiffness at the grasp) / (body mass) stays well below 1.
#include "cressim/layout.h"
#include "cressim/particle.h"
#include "cressim/quat.h"
#include "cressim/rigid.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<BodyModel> bodies;
StructuredBuffer<ParticleAttachment> attachments;
StructuredBuffer<float4> positions;
StructuredBuffer<float4> rigid_forces;
StructuredBuffer<float4> body_positions;
StructuredBuffer<float4> body_rotations;
RWStructuredBuffer<float4> body_linear_velocities;
RWStructuredBuffer<float4> body_angular_velocities;

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint env = id.x;
  if (env >= pc.env_count || pc.has_rigid == 0) return;
  const float dt = pc.gravity.w * pc.grid.w;
  const uint per_env = pc.attachment_count / max(pc.env_count, 1u);
  for (uint s = env * per_env; s < (env + 1) * per_env; ++s) {
    const ParticleAttachment at = attachments[s];
    if (at.ids.z != ATTACH_ACTIVE || at.local.w > 0 || at.ids.x >= pc.particle_count) continue;
    const uint b = at.ids.y;
    const BodyModel m = bodies[b];
    const float4 load = rigid_forces[at.ids.x];  // the last substep's alone bore 1.3x the mean at 2 substeps
    if (m.inv_inertia.w <= 0 || uint(load.w) != b + 1) continue;
    const float4 q = body_rotations[b];
    const float3 torque = cross(positions[at.ids.x].xyz - body_positions[b].xyz, load.xyz);
    body_linear_velocities[b].xyz += m.inv_inertia.w * dt * load.xyz;
    body_angular_velocities[b].xyz += dt * quat_rotate(q, m.inv_inertia.xyz * quat_unrotate(q, torque));
  }
}
