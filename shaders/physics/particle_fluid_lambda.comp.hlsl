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

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint i = id.x;
  if (i >= pc.particle_count) return;
  const uint4 ph = phases[i];
  if (ph.x != PARTICLE_FLUID || (ph.w & PARTICLE_ACTIVE) == 0) return;
  const ParticleObject o = objects[ph.y];
  const Kernel K = make_kernel(o.material.x);
  const float rho0 = o.material.w;
  const float3 xi = positions[i].xyz;
  float density, sum_squares = 0;
  float3 grad_i;
  fluid_boundary(i, xi, ph.z, o.material.x, particle_mass(positions[i]), K, density, grad_i);
  wall_gradients[i] = float4(grad_i, 0);
  grad_i /= rho0;
  FOR_EACH_NEIGHBOR(i, j, xj, j_fluid, 1, {
    if (j_fluid) {
      const float3 r = xi - xj.xyz;
      const float m = particle_mass(xj);
      density += m * spiky(K, dot(r, r));
      if (j != i) {
        const float3 g = (m / rho0) * spiky_gradient(K, r);
        grad_i += g;
        sum_squares += dot(g, g);
      }
    }
  })
  const float C = max(density / rho0 - 1, 0.0);
  densities[i] = density;
  fluid_lambdas[i] = C > 0 ? -C / (sum_squares + dot(grad_i, grad_i) + 1e-6) : 0;
}
