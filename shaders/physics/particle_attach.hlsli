// Attachment slot a applied (particle_attach.comp.hlsl says how). Expects `pc`, the body state,
// `attachments`, `orientations` and `orientation_weights` declared, and ATTACHED_POSITION(i) the
// particle's position (default positions[i]; particle_iterations reads group memory).
#ifndef ATTACHED_POSITION
#define ATTACHED_POSITION(i) positions[i]
#endif

// XPBD share of one constraint on one particle or frame of inverse mass w (the body is not moved)
float share_of(float w, float compliance) {
  const float alpha = compliance / (pc.gravity.w * pc.gravity.w);
  return w > 0 ? w / (w + alpha) : 1;
}

void apply_attachment(uint a) {
  ParticleAttachment at = attachments[a];
  if (at.ids.z == ATTACH_FREE || at.ids.x >= pc.particle_count || pc.has_rigid == 0) return;
  const uint b = at.ids.y;
  // the body where it is at the end of this substep: the rigid step already ran the whole frame
  const float frame_left = pc.gravity.w * pc.grid.w * (1 - pc.grid.y);
  const float3 p = body_positions[b].xyz - body_linear_velocities[b].xyz * frame_left;
  const float4 q = quat_add_rotation(body_rotations[b], -body_angular_velocities[b].xyz * frame_left);
  const uint e = at.hold.x;
  const bool holds = e < pc.edge_count;
  float4 x = ATTACHED_POSITION(at.ids.x);
  if (at.ids.z == ATTACH_PENDING) {
    at.local.xyz = quat_unrotate(q, x.xyz - p);
    if (holds && at.hold.y == HOLD_FRAME_CAPTURE) at.frame = quat_mul(quat_conj(q), orientations[e]);
    at.ids.z = ATTACH_ACTIVE;
    attachments[a] = at;
  }
  const float3 target = p + quat_rotate(q, at.local.xyz);
  x.xyz += share_of(x.w, at.local.w) * (target - x.xyz);
  ATTACHED_POSITION(at.ids.x) = x;
  if (!holds) return;
  const float4 qe = orientations[e];
  float4 goal = normalize(quat_mul(q, at.frame));
  if (dot(goal, qe) < 0) goal = -goal;  // the nearer of +-goal
  orientations[e] = normalize(qe + share_of(orientation_weights[e], at.local.w) * (goal - qe));
}

// The env's attachment slots, applied by a workgroup holding its particles (`threads` threads,
// this one `lane`); a slot written past the host's checks with another env's particle is left
// alone
void apply_env_attachments(uint env, uint first, uint count, uint lane, uint threads) {
  const uint slots = pc.attachment_count / max(pc.env_count, 1u);
  for (uint s = lane; s < slots; s += threads) {
    const uint a = env * slots + s, p = attachments[a].ids.x;
    if (p >= first && p - first < count) apply_attachment(a);
  }
}
