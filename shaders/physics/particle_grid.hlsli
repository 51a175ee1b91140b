// The neighbour grid, keyed on (env, cell): a particle's cell and env hash to a bucket; buckets
// are counted, prefix-summed into starts, filled, and each bucket sorted by particle index, so
// a neighbour walk visits the same particles in the same order however many envs share the
// table. A walk accepts only particles whose stored (cell, env) is the cell it looks at, so
// neither another env nor a hash collision ever yields a neighbour.
// Expects `pc` declared by the including kernel; particle_neighbor_list walks the 27 cells.

uint cell_bucket(int3 c, uint env) {
  const uint h = (uint(c.x) * 73856093u) ^ (uint(c.y) * 19349663u) ^ (uint(c.z) * 83492791u) ^ (env * 2654435761u);
  return (h ^ (h >> 15)) & (pc.table_size - 1);
}

int3 cell_of(float3 x) { return int3(floor(x / pc.grid.x)); }
