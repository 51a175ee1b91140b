// Puts every entity row of an env flagged in env.reset_mask back to its authored transform and
// counts the reset. One thread per row and per env (threads = max(rows, envs)).
#include "cressim/layout.h"

[[vk::push_constant]] ConstantBuffer<ResetEnvsConstants> pc;
StructuredBuffer<uint> entity_env;
StructuredBuffer<uint> reset_mask;
StructuredBuffer<float4> initial_positions;
StructuredBuffer<float4> initial_rotations;
RWStructuredBuffer<float4> positions;
RWStructuredBuffer<float4> rotations;
RWStructuredBuffer<uint> reset_count;

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint i = id.x;
  if (i < pc.env_count && reset_mask[i] != 0) reset_count[i] += 1;
  if (i >= pc.row_count || reset_mask[entity_env[i]] == 0) return;
  positions[i] = initial_positions[i];
  rotations[i] = initial_rotations[i];
}
