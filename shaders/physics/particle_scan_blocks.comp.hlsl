// Neighbour grid, step 2b: exclusive prefix sum of the block totals (one group; item_count blocks).
#include "cressim/particle.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
RWStructuredBuffer<uint> block_sums;

groupshared uint scan[256];

[numthreads(256, 1, 1)]
void main(uint3 local : SV_GroupThreadID) {
  const uint t = local.x, n = pc.item_count, chunk = (n + 255) / 256;
  const uint first = min(t * chunk, n), last = min(first + chunk, n);
  uint sum = 0;
  for (uint k = first; k < last; ++k) sum += block_sums[k];
  scan[t] = sum;
  GroupMemoryBarrierWithGroupSync();
  for (uint offset = 1; offset < 256; offset <<= 1) {
    const uint add = t >= offset ? scan[t - offset] : 0;
    GroupMemoryBarrierWithGroupSync();
    scan[t] += add;
    GroupMemoryBarrierWithGroupSync();
  }
  uint running = scan[t] - sum;
  for (uint k = first; k < last; ++k) {
    const uint v = block_sums[k];
    block_sums[k] = running;
    running += v;
  }
}
