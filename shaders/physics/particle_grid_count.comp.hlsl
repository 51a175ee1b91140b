// Neighbour grid, step 1: each active particle's (cell, env) and bucket; buckets counted.
#include "cressim/layout.h"
#include "cressim/particle.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<uint4> phases;
StructuredBuffer<float4> positions;
RWStructuredBuffer<int4> cells;
RWStructuredBuffer<uint> buckets;
RWStructuredBuffer<uint> cell_counts;

#include "particle_grid.hlsli"

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint i = id.x;
  if (i >= pc.particle_count) return;
  const uint4 ph = phases[i];
  if ((ph.w & PARTICLE_ACTIVE) == 0) {
    cells[i] = int4(0x7fffffff, 0x7fffffff, 0x7fffffff, -1);  // matches no cell
    buckets[i] = 0xffffffffu;
    return;
  }
  const int3 c = cell_of(positions[i].xyz);
  cells[i] = int4(c, int(ph.z));
  const uint b = cell_bucket(c, ph.z, pc.table_size);
  buckets[i] = b;
  InterlockedAdd(cell_counts[b], 1u);
}
