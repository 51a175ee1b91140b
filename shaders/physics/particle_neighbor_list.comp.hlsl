// Neighbour grid, step 5: each active particle lists the particles neighbor_near() it, at most
// PARTICLE_MAX_NEIGHBORS in walk order, each marked with its kind. Walking 27 cells per iteration
// pass cost several times the list (a fluid cell holds 8 particles, a particle about 40 neighbours).
// PARTICLE_LIST_LANES adjacent threads (lanes of one subgroup, in order: the engine checks the
// subgroup is wide enough) share a particle: they test a cell's candidates that many at a time
// and a ballot gives each accepted one its slot, so the list keeps the walk's order. One thread
// a particle left the walk's chain of dependent loads (bucket, candidate, its cell and position)
// bare: 0.79 ms of FluidPour's frame at 128 envs on an H100, 0.67 ms with 4 lanes. The passes
// that read the lists stay at one thread a particle: split over lanes they were slower.
#include "cressim/layout.h"
#include "cressim/particle.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<uint4> phases;
StructuredBuffer<float4> positions;
StructuredBuffer<int4> cells;
StructuredBuffer<uint> cell_starts;
StructuredBuffer<uint> cell_counts;
StructuredBuffer<uint> sorted;
RWStructuredBuffer<uint> neighbor_counts;
RWStructuredBuffer<uint> neighbor_lists;

#include "particle_grid.hlsli"

static const uint LANES = PARTICLE_LIST_LANES;

// bit l set where lane l of this thread's particle passes b
uint lanes_ballot(bool b) {
  const uint4 votes = WaveActiveBallot(b);
  const uint first = WaveGetLaneIndex() & ~(LANES - 1);
  return (votes[first >> 5] >> (first & 31)) & ((1u << LANES) - 1);
}

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint i = id.x / LANES, lane = id.x % LANES;
  if (i >= pc.particle_count) return;
  uint count = 0;
  if ((phases[i].w & PARTICLE_ACTIVE) != 0) {
    const float3 xi = positions[i].xyz;
    const int4 home = cells[i];
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int4 cell = int4(home.xyz + int3(dx, dy, dz), home.w);
          const uint bucket = cell_bucket(cell.xyz, uint(cell.w), pc.table_size);
          const uint start = cell_starts[bucket], end = start + cell_counts[bucket];
          for (uint first = start; first < end; first += LANES) {
            const uint k = first + lane;
            uint j = 0;
            bool near = false;
            if (k < end) {
              j = sorted[k];
              near = all(cells[j] == cell) && neighbor_near(xi, positions[j].xyz);
            }
            const uint taken = lanes_ballot(near);
            const uint slot = count + countbits(taken & ((1u << lane) - 1));
            if (near && slot < PARTICLE_MAX_NEIGHBORS)
              neighbor_lists[slot * pc.particle_count + i] = neighbor_entry(j);
            count += countbits(taken);
          }
        }
  }
  if (lane == 0) neighbor_counts[i] = min(count, PARTICLE_MAX_NEIGHBORS);
}
