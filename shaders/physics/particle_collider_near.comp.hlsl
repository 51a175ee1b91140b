// Per substep, the colliders of its env each particle may touch during the iterations: bit b of
// collider_near is the env's collider b (the first 32; any beyond are always visited). The
// gather and the fluid's wall density visit only these. Visiting every collider in each of them
// cost FluidPour's frame about 0.4 of its 2.9 ms at 128 envs (an H100), with a dozen walls an
// env and most particles far from most of them.
// A collider is near when it comes within the particle's reach (its radius; a fluid particle's
// wall_reach, for the wall density) plus a cell of the neighbour grid, the motion the
// iterations may add, at its pose at the end of the substep (the one every pass uses).
#include "cressim/layout.h"
#include "cressim/particle.h"
#include "cressim/quat.h"
#include "cressim/rigid.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<ParticleObject> objects;
StructuredBuffer<uint4> phases;
StructuredBuffer<float4> positions;
RWStructuredBuffer<uint> collider_near;

#include "particle_collide.hlsli"
#include "particle_fluid.hlsli"
#include "particle_collider_near.hlsli"

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint i = id.x;
  if (i < pc.particle_count) collider_near[i] = colliders_near(phases[i], positions[i].xyz);
}
