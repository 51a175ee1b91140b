// Position-based fluids, per iteration: each fluid particle's SPH density and its constraint's
// multiplier, C = max(rho / rho0 - 1, 0) (Macklin & Mueller 2013; unilateral, so the free
// surface is not pulled together). Rigid walls add their density (particle_fluid_boundary.hlsli).
#include "cressim/layout.h"
#include "cressim/particle.h"
#include "cressim/quat.h"
#include "cressim/rigid.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<ParticleObject> objects;
StructuredBuffer<uint4> phases;
StructuredBuffer<float4> positions;
RWStructuredBuffer<float> densities;
RWStructuredBuffer<float> fluid_lambdas;
StructuredBuffer<uint> collider_near;
RWStructuredBuffer<float4> wall_gradients;  // for particle_neighbors, at these positions

#include "particle_neighbor_list.hlsli"
#include "particle_fluid.hlsli"
#include "particle_collide.hlsli"
#include "particle_fluid_boundary.hlsli"

#include "particle_fluid_density.hlsli"

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint i = id.x;
  if (i >= pc.particle_count) return;
  const uint4 ph = phases[i];
  if (ph.x != PARTICLE_FLUID || (ph.w & PARTICLE_ACTIVE) == 0) return;
  float density;
  float3 wall;
  fluid_lambdas[i] = fluid_multiplier(i, ph, positions[i], density, wall);
  densities[i] = density;
  wall_gradients[i] = float4(wall, 0);
}
