// Strand stretch-shear (Kugelstadt & Schoemer 2016): the segment p0 -> p1 over its rest length
// equals its frame's z axis, Gamma = (p1 - p0) / l - q e3 q* = 0. Positions and the frame share
// the correction by inverse mass and inverse inertia; this couples twist to the centreline.
#include "particle_constraint.hlsli"
#include "cressim/quat.h"

RWStructuredBuffer<float4> orientations;
StructuredBuffer<float> orientation_weights;

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint c = constraint_index(id.x);
  if (c == CRESSIM_NONE) return;
  const ParticleConstraint rec = constraints[c];
  const uint p0 = rec.particles.x, p1 = rec.particles.y, e = rec.particles.z - pc.particle_count;
  const float l = rec.params.x;
  const float4 x0 = positions[p0], x1 = positions[p1];
  const float4 q = orientations[e];
  const float wq = orientation_weights[e];
  float3 gamma = (x1.xyz - x0.xyz) / l - quat_rotate(q, float3(0, 0, 1));
  const float denom = (x0.w + x1.w) / l + 4 * wq * l;
  if (denom <= 1e-20) return;
  gamma /= denom;
  positions[p0].xyz += x0.w * gamma;
  positions[p1].xyz -= x1.w * gamma;
  // q e3* = (-q.y, q.x, -q.w, q.z) as xyzw
  const float4 dq = 2 * wq * l * quat_mul(float4(gamma, 0), float4(-q.y, q.x, -q.w, q.z));
  orientations[e] = normalize(q + dq);
}
