// Neighbour grid, step 4: each bucket sorted by particle index, so that neighbour sums add the
// same terms in the same order every run (bit-identical envs, whatever else is in the table).
#include "cressim/layout.h"
#include "cressim/particle.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<uint> cell_starts;
StructuredBuffer<uint> cell_counts;
RWStructuredBuffer<uint> sorted;

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint b = id.x;
  if (b >= pc.table_size) return;
  const uint start = cell_starts[b], n = cell_counts[b];
  for (uint k = 1; k < n; ++k) {
    const uint v = sorted[start + k];
    uint m = k;
    while (m > 0 && sorted[start + m - 1] > v) {
      sorted[start + m] = sorted[start + m - 1];
      --m;
    }
    sorted[start + m] = v;
  }
}
