// Each particle's neighbours, listed once per substep by particle_neighbor_list (the grid walk,
// in its deterministic order) or particle_block_grid.hlsli (the same walk in group memory); the
// iteration passes read the list instead of walking 27 cells.
// Entry k of particle i is at k * particle_count + i so that a warp's reads are contiguous.
// Expects `positions` declared by the including kernel, or NEIGHBOR_POSITION(j) defined first
// (particle_iterations reads the env's particles from group memory). A kernel that writes the
// lists itself (particle_block_grid.hlsli) declares them first and defines NEIGHBOR_LISTS_WRITTEN.
#ifndef NEIGHBOR_POSITION
#define NEIGHBOR_POSITION(j) positions[j]
#endif
#ifndef NEIGHBOR_LISTS_WRITTEN
StructuredBuffer<uint> neighbor_counts;
StructuredBuffer<uint> neighbor_lists;
#endif

// visits particle i's neighbours j (i itself included) with xj their position and j_fluid its
// kind, `batch` at a time: their entries and positions are loaded together. A pass that reads
// several fields of each neighbour gains from batches of 4 if BODY loads them before any branch
// (the fluid velocity passes, 0.42 -> 0.34 ms of FluidPour's frame at 128 envs on an H100); the
// density and correction passes lost with them (0.64 -> 0.81 ms), so they take one at a time.
// The batch loops unroll fully: BODY must not break or continue (a loop left rolled keeps its
// arrays in memory).
#define FOR_EACH_NEIGHBOR(i, j, xj, j_fluid, batch, BODY)                                            \
  {                                                                                                  \
    const uint count_ = neighbor_counts[i];                                                          \
    for (uint k_ = 0; k_ < count_; k_ += (batch)) {                                                  \
      uint entry_[batch];                                                                            \
      float4 x_[batch];                                                                              \
      [unroll] for (uint u_ = 0; u_ < (batch); ++u_)                                                 \
        entry_[u_] = neighbor_lists[min(k_ + u_, count_ - 1) * pc.particle_count + (i)];            \
      [unroll] for (uint u_ = 0; u_ < (batch); ++u_)                                                 \
        x_[u_] = NEIGHBOR_POSITION(entry_[u_] & ~PARTICLE_NEIGHBOR_FLUID);                           \
      [unroll] for (uint u_ = 0; u_ < (batch); ++u_) {                                               \
        if (k_ + u_ < count_) {                                                                      \
          const uint j = entry_[u_] & ~PARTICLE_NEIGHBOR_FLUID;                                      \
          const bool j_fluid = (entry_[u_] & PARTICLE_NEIGHBOR_FLUID) != 0;                          \
          const float4 xj = x_[u_];                                                                  \
          BODY                                                                                       \
        }                                                                                            \
      }                                                                                              \
    }                                                                                                \
  }
