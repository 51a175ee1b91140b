// Rigid-particle attachments, after each gather: an attached particle is placed at its body
// point (rigidly, or part of the way for a compliant one); a pending slot first takes the local
// offset from the current poses. Slots are created and released by writing
// control.particle_attachments, so no buffer changes size.
#include "cressim/layout.h"
#include "cressim/particle.h"
#include "cressim/quat.h"
#include "cressim/rigid.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<float4> body_positions;
StructuredBuffer<float4> body_rotations;
StructuredBuffer<float4> body_linear_velocities;
RWStructuredBuffer<ParticleAttachment> attachments;
RWStructuredBuffer<float4> positions;

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint a = id.x;
  if (a >= pc.attachment_count) return;
  ParticleAttachment at = attachments[a];
  if (at.ids.z == ATTACH_FREE || at.ids.x >= pc.particle_count || pc.has_rigid == 0) return;
  const uint b = at.ids.y;
  const float frame_left = pc.gravity.w * pc.grid.w * (1 - pc.grid.y);
  const float3 p = body_positions[b].xyz - body_linear_velocities[b].xyz * frame_left;
  const float4 q = body_rotations[b];
  float4 x = positions[at.ids.x];
  if (at.ids.z == ATTACH_PENDING) {
    at.local.xyz = quat_unrotate(q, x.xyz - p);
    at.ids.z = ATTACH_ACTIVE;
    attachments[a] = at;
  }
  const float3 target = p + quat_rotate(q, at.local.xyz);
  // compliance as in XPBD for one constraint on one particle (the body is not moved)
  const float alpha = at.local.w / (pc.gravity.w * pc.gravity.w);
  const float share = x.w > 0 ? x.w / (x.w + alpha) : 1;
  x.xyz += share * (target - x.xyz);
  positions[at.ids.x] = x;
}
