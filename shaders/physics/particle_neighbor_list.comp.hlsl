// Neighbour grid, step 5: each active particle lists the particles within the grid's reach
// (the cell size: the widest fluid kernel or contact) plus a 5 % skin for what moves into
// reach during the iterations, at most PARTICLE_MAX_NEIGHBORS in walk order. Walking 27 cells
// per iteration pass cost several times the list (a fluid cell holds 8 particles, a particle
// about 40 neighbours).
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

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint i = id.x;
  if (i >= pc.particle_count) return;
  uint count = 0;
  if ((phases[i].w & PARTICLE_ACTIVE) != 0) {
    const float3 xi = positions[i].xyz;
    const float reach = 1.05 * pc.grid.x;
    FOR_EACH_GRID_NEIGHBOR(i, j, {
      const float3 r = positions[j].xyz - xi;
      if (dot(r, r) < reach * reach && count < PARTICLE_MAX_NEIGHBORS) {
        neighbor_lists[count * pc.particle_count + i] = j;
        ++count;
      }
    })
  }
  neighbor_counts[i] = count;
}
