// Strand bend and twist (Kugelstadt & Schoemer 2016): the Darboux vector between neighbouring
// segment frames, Omega = q0* q1, is pulled to its rest value (straight, untwisted: identity)
// component by component: x, y bending, z twist. Each component's share follows XPBD's first
// step, k = (w0 + w1) / (w0 + w1 + compliance / h^2): params.x bend compliance, params.y twist.
#include "particle_constraint.hlsli"
#include "cressim/quat.h"

RWStructuredBuffer<float4> orientations;
StructuredBuffer<float> orientation_weights;

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint c = constraint_index(id.x);
  if (c == CRESSIM_NONE) return;
  const ParticleConstraint rec = constraints[c];
  const uint e0 = rec.particles.x - pc.particle_count, e1 = rec.particles.y - pc.particle_count;
  const float4 q0 = orientations[e0], q1 = orientations[e1];
  const float w0 = orientation_weights[e0], w1 = orientation_weights[e1], w = w0 + w1;
  if (w <= 0) return;
  const float4 rest = float4(0, 0, 0, 1);
  float4 omega = quat_mul(quat_conj(q0), q1);
  // the closer of +-rest (q and -q are the same rotation)
  const float4 minus = omega - rest, plus = omega + rest;
  omega = dot(minus, minus) > dot(plus, plus) ? plus : minus;
  const float h2 = pc.gravity.w * pc.gravity.w;
  const float3 k = w / (w + float3(rec.params.x, rec.params.x, rec.params.y) / h2);
  const float4 delta = float4(omega.xyz * k / w, 0);
  orientations[e0] = normalize(q0 + w0 * quat_mul(q1, delta));
  orientations[e1] = normalize(q1 - w1 * quat_mul(q0, delta));
}
