// The neighbour grid, keyed on (env, cell): a particle's cell and env hash to a bucket; buckets
// are counted, prefix-summed into starts, filled, and each bucket sorted by particle index, so
// a neighbour walk visits the same particles in the same order however many envs share the
// table. A walk accepts only particles whose stored (cell, env) is the cell it looks at, so
// neither another env nor a hash collision ever yields a neighbour.
// Expects `pc`, `cells`, `cell_starts`, `cell_counts`, `sorted` declared by the including kernel.

uint cell_bucket(int3 c, uint env) {
  const uint h = (uint(c.x) * 73856093u) ^ (uint(c.y) * 19349663u) ^ (uint(c.z) * 83492791u) ^ (env * 2654435761u);
  return (h ^ (h >> 15)) & (pc.table_size - 1);
}

int3 cell_of(float3 x) { return int3(floor(x / pc.grid.x)); }

// visits every particle j in the 27 cells around particle i's cell (i itself included)
#define FOR_EACH_GRID_NEIGHBOR(i, j, BODY)                                                 \
  {                                                                                   \
    const int4 home_ = cells[i];                                                      \
    for (int dz_ = -1; dz_ <= 1; ++dz_)                                               \
      for (int dy_ = -1; dy_ <= 1; ++dy_)                                             \
        for (int dx_ = -1; dx_ <= 1; ++dx_) {                                         \
          const int4 cell_ = int4(home_.xyz + int3(dx_, dy_, dz_), home_.w);          \
          const uint bucket_ = cell_bucket(cell_.xyz, uint(cell_.w));                 \
          const uint start_ = cell_starts[bucket_], end_ = start_ + cell_counts[bucket_]; \
          for (uint k_ = start_; k_ < end_; ++k_) {                                   \
            const uint j = sorted[k_];                                                \
            if (any(cells[j] != cell_)) continue;                                     \
            BODY                                                                      \
          }                                                                           \
        }                                                                             \
  }
