// Puts every entity row of an env flagged in env.reset_mask back to its authored transform.
#include "cressim/layout.h"

[[vk::push_constant]] ConstantBuffer<ResetEnvsConstants> pc;
StructuredBuffer<uint> entity_env;
StructuredBuffer<uint> reset_mask;
StructuredBuffer<float4> initial_positions;
StructuredBuffer<float4> initial_rotations;
RWStructuredBuffer<float4> positions;
RWStructuredBuffer<float4> rotations;

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint row = id.x;
  if (row >= pc.row_count || reset_mask[entity_env[row]] == 0) return;
  positions[row] = initial_positions[row];
  rotations[row] = initial_rotations[row];
}
