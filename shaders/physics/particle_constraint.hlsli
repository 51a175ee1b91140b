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

#include "particle_xpbd.hlsli"
