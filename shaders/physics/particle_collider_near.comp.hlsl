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

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint i = id.x;
  if (i >= pc.particle_count) return;
  const uint4 ph = phases[i];
  uint near = 0;
  if ((ph.w & PARTICLE_ACTIVE) != 0) {
    const float3 x = positions[i].xyz;
    const float r = objects[ph.y].material.x;
    const float reach = (ph.x == PARTICLE_FLUID ? wall_reach(make_kernel(r), r) : r) + pc.grid.x;
    const EnvRigidRange range = env_rigid_ranges[ph.z];
    const uint first = range.bodies.z, end = first + min(range.bodies.w, 32u);
    for (uint c = first; c < end; ++c) {
      const ColliderModel cm = colliders[c];
      float3 n;
      float depth;
      if (meets_particles(cm) && sphere_penetration(x, reach, cm, collider_pose(cm), n, depth)) near |= 1u << (c - first);
    }
  }
  collider_near[i] = near;
}
