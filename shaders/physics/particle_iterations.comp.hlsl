// A substep's iterations in one workgroup per env, for models whose iterations hold nothing but
// the distance and volume families, particle contacts, colliders and attachments: no fluid,
// strands, needles, tendons, dynamic bodies to push or elastic tets (ParticleSystem picks it;
// strands bring their stretch chains, and a bend family would take this pass past the 32 storage
// buffers lavapipe allows a stage).
// The env's particles stay in group memory while each contact iteration runs the families their
// share of the iterations (particle_block.hlsli, in the families' order), then the particle
// contacts from those positions (as particle_neighbors), the colliders (as particle_gather) and
// the env's attachment slots (as particle_attach). That is the passes' sweep in one dispatch a
// substep instead of five a contact iteration: at SoftBodyPush's 16 contact iterations each
// family's dispatch cost about 20 us beyond its colour steps (H100, benchmarks/README.md). It also
// marks the colliders near each particle first and takes the velocities last (the passes
// particle_collider_near and particle_velocity, two dispatches a substep fewer).
// pc.item_offset: the families' iterations a substep; pc.item_count: the contact iterations.
#ifndef CRESSIM_BLOCK
#error particle_iterations is built with CRESSIM_BLOCK only (cmake/shaders.cmake)
#endif
#include "particle_iterations_kernel.hlsli"
// each family's block records, multipliers and (first, count) per env and colour; a family the
// model lacks has stand-ins and no colours
StructuredBuffer<uint4> family_colours;  // x distance, y volume: colours
StructuredBuffer<uint4> distance_records;
RWStructuredBuffer<float> distance_lambdas;
StructuredBuffer<uint2> distance_colours;
StructuredBuffer<uint4> volume_records;
RWStructuredBuffer<float> volume_lambdas;
StructuredBuffer<uint2> volume_colours;

#include "particle_xpbd.hlsli"
#include "particle_block.hlsli"
#include "particle_distance.hlsli"
#include "particle_volume.hlsli"
#include "particle_neighbor_list.hlsli"
#include "particle_contact.hlsli"
#include "particle_collide.hlsli"
#include "particle_fluid.hlsli"
#include "particle_collider_near.hlsli"
#include "particle_substep_velocity.hlsli"
#include "particle_gather.hlsli"
#include "particle_attach.hlsli"

static const uint THREADS = 256;
static const uint PER_THREAD = (CRESSIM_BLOCK + THREADS - 1) / THREADS;  // particles a thread

[numthreads(THREADS, 1, 1)]
void main(uint3 group : SV_GroupID, uint3 thread : SV_GroupThreadID) {
  const uint env = group.x, lane = thread.x;
  const uint first = env_ranges[env].range.x, count = env_ranges[env].range.y;
  block_first = first;
  for (uint l = lane; l < count; l += THREADS) {
    block_x[l] = positions[first + l];
    // the colliders near each particle, as particle_collider_near would mark them
    if (pc.has_rigid != 0) collider_near[first + l] = colliders_near(phases[first + l], block_x[l].xyz);
  }
  const uint4 colours = family_colours[0];
  GroupMemoryBarrierWithGroupSync();
  const uint iterations = pc.item_offset, contacts = pc.item_count;
  for (uint k = 0; k < contacts; ++k) {
    // contact iteration k follows the families' iterations up to floor((k + 1) I / C), as the passes do
    const uint passes = (k + 1) * iterations / contacts - k * iterations / contacts;
    BLOCK_SOLVE_COLOURS(evaluate_distance, distance_records, distance_lambdas, distance_colours, BLOCK_NO_ZW, env,
                        colours.x, passes, lane, THREADS)
    BLOCK_SOLVE_COLOURS(evaluate_volume, volume_records, volume_lambdas, volume_colours, BLOCK_NO_ZW, env, colours.y,
                        passes, lane, THREADS)
    // each particle's contacts, all from the positions the families left (Jacobi, as the passes)
    float3 delta[PER_THREAD];
    [unroll] for (uint q = 0; q < PER_THREAD; ++q) {
      delta[q] = float3(0, 0, 0);
      const uint l = lane + q * THREADS;
      if (l >= count) continue;
      const uint i = first + l;
      const uint4 ph = phases[i];
      const float4 xi = block_x[l];
      if ((ph.w & PARTICLE_ACTIVE) == 0 || xi.w <= 0) continue;
      const float ri = objects[ph.y].material.x;
      float3 contact = float3(0, 0, 0);
      float touching = 0;
      FOR_EACH_NEIGHBOR(i, j, xj, j_fluid, 1, {
        if (j != i) {
          const uint4 pj = phases[j];
          if (particles_collide(i, ph, j, pj))
            add_contact(xi.xyz - xj.xyz, ri + objects[pj.y].material.x, xi.w, xj.w, contact, touching);
        }
      })
      if (touching > 0) delta[q] = contact / touching;
    }
    GroupMemoryBarrierWithGroupSync();
    // then the colliders near each particle
    [unroll] for (uint q = 0; q < PER_THREAD; ++q) {
      const uint l = lane + q * THREADS;
      if (l >= count) continue;
      const uint i = first + l;
      const uint4 ph = phases[i];
      float4 x = block_x[l];
      if ((ph.w & PARTICLE_ACTIVE) == 0 || x.w <= 0) continue;
      x.xyz += delta[q];
      if (pc.has_rigid != 0) x = collide_near_colliders(i, ph, x);
      block_x[l] = x;
    }
    GroupMemoryBarrierWithGroupSync();
    // then the env's attachment slots
    apply_env_attachments(env, first, count, lane, THREADS);
    GroupMemoryBarrierWithGroupSync();
  }
  // and the substep's velocities, as particle_velocity would take them
  for (uint l = lane; l < count; l += THREADS) {
    const uint i = first + l;
    positions[i] = block_x[l];
    if ((phases[i].w & PARTICLE_ACTIVE) != 0) velocities[i].xyz = substep_velocity(block_x[l].xyz, prev_positions[i].xyz);
  }
}
