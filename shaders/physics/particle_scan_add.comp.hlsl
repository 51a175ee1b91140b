// Neighbour grid, step 2c: block offsets added, so cell_starts is the table-wide exclusive sum.
#include "cressim/particle.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<uint> block_sums;
RWStructuredBuffer<uint> cell_starts;

[numthreads(256, 1, 1)]
void main(uint3 id : SV_DispatchThreadID, uint3 group : SV_GroupID) {
  if (id.x < pc.table_size) cell_starts[id.x] += block_sums[group.x];
}
