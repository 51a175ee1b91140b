// A substep's iterations in one workgroup per env, a thread a particle, for models of fluid alone
// against static and kinematic colliders (no soft bodies, strands, needles, tendons or dynamic
// bodies for the fluid to push; ParticleSystem picks it). It lists the env's neighbours itself
// (particle_block_grid.hlsli: the neighbour grid's passes do not run). The env's particles and
// multipliers stay in group memory while each contact iteration takes every particle's density and multiplier (as
// particle_fluid_lambda), then its correction from its neighbours' multipliers and the walls (as
// particle_neighbors), the colliders near it (as particle_gather) and the env's attachment slots
// (as particle_attach), a group barrier between them. One dispatch a substep instead of four a
// contact iteration: one env of FluidPour's 960 particles took 22 us a density pass, the walk of
// one thread, with a dispatch around it (H100, benchmarks/README.md). Like particle_iterations it
// marks the colliders near each particle first and takes the velocities last.
// pc.item_count: the contact iterations.
#ifndef CRESSIM_BLOCK
#error particle_fluid_iterations is built with CRESSIM_BLOCK only (cmake/shaders.cmake)
#endif
#include "particle_iterations_kernel.hlsli"
RWStructuredBuffer<float> densities;  // the last iteration's, for the velocity passes
RWStructuredBuffer<uint> neighbor_counts;
RWStructuredBuffer<uint> neighbor_lists;
#define NEIGHBOR_LISTS_WRITTEN

groupshared float block_lambda[CRESSIM_BLOCK];

#include "particle_grid.hlsli"
#include "particle_block_grid.hlsli"
#include "particle_neighbor_list.hlsli"
#include "particle_fluid.hlsli"
#include "particle_collide.hlsli"
#include "particle_fluid_boundary.hlsli"
#include "particle_fluid_density.hlsli"
#include "particle_collider_near.hlsli"
#include "particle_substep_velocity.hlsli"
#include "particle_gather.hlsli"
#include "particle_attach.hlsli"

[numthreads(CRESSIM_BLOCK, 1, 1)]
void main(uint3 group : SV_GroupID, uint3 thread : SV_GroupThreadID) {
  const uint env = group.x, l = thread.x;
  const uint first = env_ranges[env].range.x, count = env_ranges[env].range.y;
  block_first = first;
  const bool mine = l < count;
  const uint i = first + l;
  const uint4 ph = mine ? phases[i] : uint4(0, 0, 0, 0);
  const bool moves = mine && (ph.w & PARTICLE_ACTIVE) != 0;
  if (mine) block_x[l] = positions[i];
  // the colliders near the particle, as particle_collider_near would mark them
  if (mine && pc.has_rigid != 0) collider_near[i] = colliders_near(ph, block_x[l].xyz);
  const ParticleObject o = objects[mine ? ph.y : 0];
  const Kernel K = make_kernel(o.material.x);
  GroupMemoryBarrierWithGroupSync();
  list_block_neighbors(env, first, count, l, CRESSIM_BLOCK);
  for (uint k = 0; k < pc.item_count; ++k) {
    // every particle's density and multiplier
    float lambda = 0, density = 0;
    float3 wall = float3(0, 0, 0);
    if (moves) lambda = fluid_multiplier(i, ph, block_x[l], density, wall);
    if (moves && k + 1 == pc.item_count) densities[i] = density;
    if (mine) block_lambda[l] = lambda;
    GroupMemoryBarrierWithGroupSync();
    // its correction, all from the same positions
    float4 x = mine ? block_x[l] : float4(0, 0, 0, 0);
    float3 delta = float3(0, 0, 0);
    if (moves && x.w > 0) {
      FOR_EACH_NEIGHBOR(i, j, xj, j_fluid, 1, {
        if (j != i) delta += density_correction(K, x.xyz - xj.xyz, xj, lambda, block_lambda[j - first]);
      })
      if (lambda != 0) delta += lambda * wall;
      delta /= max(o.material.w, 1e-9);
    }
    GroupMemoryBarrierWithGroupSync();
    // then the colliders near it
    if (moves && x.w > 0) {
      x.xyz += delta;
      if (pc.has_rigid != 0) x = collide_near_colliders(i, ph, x);
      block_x[l] = x;
    }
    GroupMemoryBarrierWithGroupSync();
    // then the env's attachment slots
    apply_env_attachments(env, first, count, l, CRESSIM_BLOCK);
    GroupMemoryBarrierWithGroupSync();
  }
  if (mine) positions[i] = block_x[l];
  // and the substep's velocity, as particle_velocity would take it
  if (moves) velocities[i].xyz = substep_velocity(block_x[l].xyz, prev_positions[i].xyz);
}
