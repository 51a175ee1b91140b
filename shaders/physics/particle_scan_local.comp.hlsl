// Neighbour grid, step 2a: exclusive prefix sum of bucket counts within blocks of 256, and each
// block's total.
#include "cressim/particle.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<uint> cell_counts;
RWStructuredBuffer<uint> cell_starts;
RWStructuredBuffer<uint> block_sums;

groupshared uint scan[256];

[numthreads(256, 1, 1)]
void main(uint3 id : SV_DispatchThreadID, uint3 local : SV_GroupThreadID, uint3 group : SV_GroupID) {
  const uint i = id.x, t = local.x;
  const uint value = i < pc.table_size ? cell_counts[i] : 0;
  scan[t] = value;
  GroupMemoryBarrierWithGroupSync();
  for (uint offset = 1; offset < 256; offset <<= 1) {
    const uint add = t >= offset ? scan[t - offset] : 0;
    GroupMemoryBarrierWithGroupSync();
    scan[t] += add;
    GroupMemoryBarrierWithGroupSync();
  }
  if (i < pc.table_size) cell_starts[i] = scan[t] - value;
  if (t == 255) block_sums[group.x] = scan[255];
}
