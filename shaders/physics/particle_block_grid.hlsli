// The env's neighbour lists built inside its own workgroup: the same lists, in the same order, as
// the neighbour grid's passes (particle_grid_count through particle_neighbor_list) give, without
// their seven dispatches over every env's particles. The env's active particles are counted into
// a hash table in group memory keyed on their cell, the table is prefix-summed, filled and each
// bucket sorted by particle, then each particle walks its 27 cells as particle_neighbor_list does.
// A cell's accepted particles come out in particle order whatever else shares its bucket, so the
// lists match the global table's entry for entry. FluidPour at 128 envs on an H100: 0.11 ms a
// substep here against 0.23 for the grid's passes (benchmarks/README.md).
// Expects `pc`, `phases` (particle_grid.hlsli), group memory `block_x` holding the env's
// particles and RW `neighbor_counts` and `neighbor_lists` declared by the including kernel.

// a power of two (cell_bucket masks with it); an env's particles fill about an eighth as many cells,
// and the fluid kernel's group memory must stay within lavapipe's 32 KB at 1024 particles
static const uint BLOCK_BUCKETS = CRESSIM_BLOCK;
static const uint BLOCK_SCAN_CHUNK = 64;              // buckets a thread sums serially
static const uint BLOCK_SCAN_CHUNKS = BLOCK_BUCKETS / BLOCK_SCAN_CHUNK;

// bucket b's particles are block_sorted[block_starts[b], block_starts[b + 1])
groupshared uint block_starts[BLOCK_BUCKETS + 1];
groupshared uint block_sorted[CRESSIM_BLOCK];
groupshared uint block_chunk_sums[BLOCK_SCAN_CHUNKS];

// env-local particle l's bucket
uint block_bucket(uint env, uint l) { return cell_bucket(cell_of(block_x[l].xyz), env, BLOCK_BUCKETS); }

// The env's particles are `first` to `first + count`; each of `threads` threads (at least
// BLOCK_SCAN_CHUNKS) takes those from `lane` on, `threads` apart. Every thread of the group calls it.
void list_block_neighbors(uint env, uint first, uint count, uint lane, uint threads) {
  for (uint b = lane; b <= BLOCK_BUCKETS; b += threads) block_starts[b] = 0;
  GroupMemoryBarrierWithGroupSync();
  for (uint l = lane; l < count; l += threads)
    if ((phases[first + l].w & PARTICLE_ACTIVE) != 0) InterlockedAdd(block_starts[block_bucket(env, l)], 1u);
  GroupMemoryBarrierWithGroupSync();
  // each bucket's end (an inclusive scan of the counts): chunk sums, then each chunk's walk
  if (lane < BLOCK_SCAN_CHUNKS) {
    uint sum = 0;
    for (uint k = 0; k < BLOCK_SCAN_CHUNK; ++k) sum += block_starts[lane * BLOCK_SCAN_CHUNK + k];
    block_chunk_sums[lane] = sum;
  }
  GroupMemoryBarrierWithGroupSync();
  if (lane < BLOCK_SCAN_CHUNKS) {
    uint end = 0;
    for (uint c = 0; c < lane; ++c) end += block_chunk_sums[c];
    for (uint k = 0; k < BLOCK_SCAN_CHUNK; ++k) {
      end += block_starts[lane * BLOCK_SCAN_CHUNK + k];
      block_starts[lane * BLOCK_SCAN_CHUNK + k] = end;
    }
    if (lane + 1 == BLOCK_SCAN_CHUNKS) block_starts[BLOCK_BUCKETS] = end;
  }
  GroupMemoryBarrierWithGroupSync();
  // fill each bucket from its end down, so that its entry ends at its start
  for (uint l = lane; l < count; l += threads)
    if ((phases[first + l].w & PARTICLE_ACTIVE) != 0) {
      uint end;
      InterlockedAdd(block_starts[block_bucket(env, l)], uint(-1), end);
      block_sorted[end - 1] = l;
    }
  GroupMemoryBarrierWithGroupSync();
  // each bucket by particle, as particle_grid_sort
  for (uint b = lane; b < BLOCK_BUCKETS; b += threads) {
    const uint start = block_starts[b], end = block_starts[b + 1];
    for (uint k = start + 1; k < end; ++k) {
      const uint v = block_sorted[k];
      uint m = k;
      while (m > start && block_sorted[m - 1] > v) {
        block_sorted[m] = block_sorted[m - 1];
        --m;
      }
      block_sorted[m] = v;
    }
  }
  GroupMemoryBarrierWithGroupSync();
  // the walk, as particle_neighbor_list
  for (uint l = lane; l < count; l += threads) {
    const uint i = first + l;
    uint listed = 0;
    if ((phases[i].w & PARTICLE_ACTIVE) != 0) {
      const float3 xi = block_x[l].xyz;
      const int3 home = cell_of(xi);
      for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const int3 cell = home + int3(dx, dy, dz);
            const uint b = cell_bucket(cell, env, BLOCK_BUCKETS);
            for (uint k = block_starts[b], end = block_starts[b + 1]; k < end; ++k) {
              const uint jl = block_sorted[k];
              const float3 xj = block_x[jl].xyz;
              if (all(cell_of(xj) == cell) && neighbor_near(xi, xj)) {
                if (listed < PARTICLE_MAX_NEIGHBORS) neighbor_lists[listed * pc.particle_count + i] = neighbor_entry(first + jl);
                ++listed;
              }
            }
          }
    }
    neighbor_counts[i] = min(listed, PARTICLE_MAX_NEIGHBORS);
  }
  GroupMemoryBarrierWithGroupSync();  // the walks read block_x, which the caller goes on to move
}
