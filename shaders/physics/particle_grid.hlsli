// The neighbour grid, keyed on (env, cell): a particle's cell and env hash to a bucket; buckets
// are counted, prefix-summed into starts, filled, and each bucket sorted by particle index, so
// a neighbour walk visits the same particles in the same order however many envs share the
// table. A walk accepts only particles whose stored (cell, env) is the cell it looks at, so
// neither another env nor a hash collision ever yields a neighbour.
// Expects `pc` and `phases` declared by the including kernel; particle_neighbor_list walks the 27
// cells (particle_block_grid.hlsli the same in one env's group memory).

// of a table of `buckets` (a power of two)
uint cell_bucket(int3 c, uint env, uint buckets) {
  const uint h = (uint(c.x) * 73856093u) ^ (uint(c.y) * 19349663u) ^ (uint(c.z) * 83492791u) ^ (env * 2654435761u);
  return (h ^ (h >> 15)) & (buckets - 1);
}

// a product, not a quotient: a compiler may take x / h as x * (1 / h) in one kernel and not in
// another, and the lists need every kernel to put a particle in the same cell
int3 cell_of(float3 x) { return int3(floor(x * pc.cell_inverse)); }

// whether xj is near enough xi to be listed: within the cell size (the widest fluid kernel or
// contact) plus a 5 % skin for what moves into reach during the iterations. `precise` keeps a
// compiler from fusing the sum into multiply-adds in one kernel and not in another: a pair at the
// reach would then be listed by one kernel's walk and not by the other's.
bool neighbor_near(float3 xi, float3 xj) {
  precise const float3 r = xj - xi;
  precise const float d2 = r.x * r.x + r.y * r.y + r.z * r.z;
  precise const float reach = 1.05 * pc.grid.x;
  return d2 < reach * reach;
}

// particle j's list entry: its index, marked when it is fluid
uint neighbor_entry(uint j) { return j | (phases[j].x == PARTICLE_FLUID ? PARTICLE_NEIGHBOR_FLUID : 0); }
