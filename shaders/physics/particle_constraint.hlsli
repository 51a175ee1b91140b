// The common part of every constraint family's pass: one XPBD step (Macklin et al. 2016) per
// constraint. lambda accumulates over the substep; compliance is divided by h^2 so stiffness
// does not depend on the iteration count once the solve has converged.
#include "cressim/layout.h"
#include "cressim/particle.h"
#include "cressim/rigid.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<ParticleConstraint> constraints;
RWStructuredBuffer<float4> positions;
RWStructuredBuffer<float> lambdas;

// control.particle_<family>_cut: nonzero switches a constraint off (cutting), set by the host
// (Engine.cut_constraints) or a task pass; the colouring stays valid for any subset
StructuredBuffer<uint> cut;

// the constraint this thread projects, or CRESSIM_NONE (past the colour, or cut)
uint constraint_index(uint thread) {
  if (thread >= pc.item_count) return CRESSIM_NONE;
  const uint c = pc.item_offset + thread;
  return cut[c] == 0 ? c : CRESSIM_NONE;
}

// the multiplier change of constraint c with value C, gradients g[k] and inverse masses w[k]
// of its n particles; the caller moves particle k by w[k] * dl * g[k]
float xpbd_step(uint c, ParticleConstraint rec, uint n, float C, float3 g[4], float w[4]) {
  const float alpha = rec.params.y / (pc.gravity.w * pc.gravity.w);
  float denom = alpha;
  for (uint k = 0; k < n; ++k) denom += w[k] * dot(g[k], g[k]);
  if (denom <= 1e-20) return 0;
  const float dl = (-C - alpha * lambdas[c]) / denom;
  lambdas[c] += dl;
  return dl;
}
