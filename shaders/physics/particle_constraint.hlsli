// The common part of every constraint family's solve pass (XPBD with Jacobi mass splitting):
// a particle in n constraints is seen by each as n times heavier, each writes its correction
// into the particle's own slot, and the gather pass applies the mean of the slots. lambda
// accumulates over the substep; compliance is divided by h^2 so stiffness does not depend on
// the iteration count.
#include "cressim/layout.h"
#include "cressim/particle.h"
#include "cressim/rigid.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<ParticleConstraint> constraints;
StructuredBuffer<uint2> slot_ranges;
StructuredBuffer<float4> positions;
RWStructuredBuffer<float4> slots;
RWStructuredBuffer<float> lambdas;

// split inverse mass of particle p
float split_weight(uint p) { return positions[p].w * float(slot_ranges[p].y); }

// one XPBD step of constraint c with value C, gradients g[k] of its n particles
void project(uint c, ParticleConstraint rec, uint n, float C, float3 g[4]) {
  const uint ids[4] = {rec.particles.x, rec.particles.y, rec.particles.z, rec.particles.w};
  const uint slot_ids[4] = {rec.slots.x, rec.slots.y, rec.slots.z, rec.slots.w};
  float w[4] = {0, 0, 0, 0};
  float denom = rec.params.y / (pc.gravity.w * pc.gravity.w);
  const float alpha = denom;
  for (uint k = 0; k < n; ++k) {
    w[k] = split_weight(ids[k]);
    denom += w[k] * dot(g[k], g[k]);
  }
  float dl = 0;
  if (denom > 1e-20) {
    dl = (-C - alpha * lambdas[c]) / denom;
    lambdas[c] += dl;
  }
  for (uint k = 0; k < n; ++k) slots[slot_ids[k]] = float4(w[k] * dl * g[k], 0);
}
