// Neighbour grid, step 3: each particle written into its bucket's range (in any order).
#include "cressim/layout.h"
#include "cressim/particle.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<uint> buckets;
StructuredBuffer<uint> cell_starts;
RWStructuredBuffer<uint> cell_fill;
RWStructuredBuffer<uint> sorted;

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint i = id.x;
  if (i >= pc.particle_count) return;
  const uint b = buckets[i];
  if (b == 0xffffffffu) return;
  uint slot;
  InterlockedAdd(cell_fill[b], 1u, slot);
  sorted[cell_starts[b] + slot] = i;
}
