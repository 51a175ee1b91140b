// Each particle's neighbours, listed once per substep by particle_neighbor_list (the grid walk,
// in its deterministic order); the iteration passes read the list instead of walking 27 cells.
// Entry k of particle i is at k * particle_count + i so that a warp's reads are contiguous.
StructuredBuffer<uint> neighbor_counts;
StructuredBuffer<uint> neighbor_lists;

// visits particle i's neighbours j (i itself included)
#define FOR_EACH_NEIGHBOR(i, j, BODY)                                      \
  {                                                                        \
    const uint count_ = neighbor_counts[i];                                \
    for (uint k_ = 0; k_ < count_; ++k_) {                                 \
      const uint j = neighbor_lists[k_ * pc.particle_count + (i)];         \
      BODY                                                                 \
    }                                                                      \
  }
