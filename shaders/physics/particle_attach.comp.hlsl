// Rigid-particle attachments, after each gather: an attached particle is placed at its body
// point (rigidly, or part of the way for a compliant one); a pending slot first takes the local
// offset from the current poses. A slot that holds a strand frame also turns that segment's
// material frame to the body's rotation times the held offset (the same share rule on the
// frame's inverse inertia), so a turning tool twists the thread. Slots are created and
// released by writing control.particle_attachments, so no buffer changes size. (The elastic
// solve leaves a rigidly held particle where it is and reports its load on the body:
// particle_tet.comp.hlsl.)
#include "cressim/layout.h"
#include "cressim/particle.h"
#include "cressim/quat.h"
#include "cressim/rigid.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<float4> body_positions;
StructuredBuffer<float4> body_rotations;
StructuredBuffer<float4> body_linear_velocities;
StructuredBuffer<float4> body_angular_velocities;
RWStructuredBuffer<ParticleAttachment> attachments;
RWStructuredBuffer<float4> positions;
RWStructuredBuffer<float4> orientations;
StructuredBuffer<float> orientation_weights;

// XPBD share of one constraint on one particle or frame of inverse mass w (the body is not moved)
float share_of(float w, float compliance) {
  const float alpha = compliance / (pc.gravity.w * pc.gravity.w);
  return w > 0 ? w / (w + alpha) : 1;
}

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint a = id.x;
  if (a >= pc.attachment_count) return;
  ParticleAttachment at = attachments[a];
  if (at.ids.z == ATTACH_FREE || at.ids.x >= pc.particle_count || pc.has_rigid == 0) return;
  const uint b = at.ids.y;
  // the body where it is at the end of this substep: the rigid step already ran the whole frame
  const float frame_left = pc.gravity.w * pc.grid.w * (1 - pc.grid.y);
  const float3 p = body_positions[b].xyz - body_linear_velocities[b].xyz * frame_left;
  const float4 q = quat_add_rotation(body_rotations[b], -body_angular_velocities[b].xyz * frame_left);
  const uint e = at.hold.x;
  const bool holds = e < pc.edge_count;
  float4 x = positions[at.ids.x];
  if (at.ids.z == ATTACH_PENDING) {
    at.local.xyz = quat_unrotate(q, x.xyz - p);
    if (holds && at.hold.y == HOLD_FRAME_CAPTURE) at.frame = quat_mul(quat_conj(q), orientations[e]);
    at.ids.z = ATTACH_ACTIVE;
    attachments[a] = at;
  }
  const float3 target = p + quat_rotate(q, at.local.xyz);
  x.xyz += share_of(x.w, at.local.w) * (target - x.xyz);
  positions[at.ids.x] = x;
  if (!holds) return;
  const float4 qe = orientations[e];
  float4 goal = normalize(quat_mul(q, at.frame));
  if (dot(goal, qe) < 0) goal = -goal;  // the nearer of +-goal
  orientations[e] = normalize(qe + share_of(orientation_weights[e], at.local.w) * (goal - qe));
}
