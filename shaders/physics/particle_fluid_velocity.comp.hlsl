// Fluid velocity terms, step 2 (Macklin & Mueller 2013, Akinci et al. 2013): XSPH viscosity,
// vorticity confinement, cohesion and surface tension (curvature), as velocity changes.
#include "cressim/layout.h"
#include "cressim/particle.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<ParticleObject> objects;
StructuredBuffer<uint4> phases;
StructuredBuffer<float4> positions;
StructuredBuffer<float4> velocity_copies;
StructuredBuffer<float> densities;
StructuredBuffer<float4> vorticities;
StructuredBuffer<float4> normals;
RWStructuredBuffer<float4> velocities;

#include "particle_neighbor_list.hlsli"
#include "particle_fluid.hlsli"

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint i = id.x;
  if (i >= pc.particle_count) return;
  const uint4 ph = phases[i];
  if (ph.x != PARTICLE_FLUID || (ph.w & PARTICLE_ACTIVE) == 0 || positions[i].w <= 0) return;
  const ParticleObject o = objects[ph.y];
  const Kernel K = make_kernel(o.material.x);
  const float rho0 = o.material.w, dt = pc.gravity.w;
  const float3 xi = positions[i].xyz, vi = velocity_copies[i].xyz, omega = vorticities[i].xyz, ni = normals[i].xyz;
  const float rho_i = max(densities[i], 1e-6);
  float3 xsph = float3(0, 0, 0), eta = float3(0, 0, 0), accel = float3(0, 0, 0);
  FOR_EACH_NEIGHBOR(i, j, xj, j_fluid, 4, {
    // the neighbour's fields, loaded before any branch: with the batch's other neighbours
    const float rho_j = max(densities[j], 1e-6);
    const float3 v_j = velocity_copies[j].xyz, omega_j = vorticities[j].xyz, n_j = normals[j].xyz;
    if (j != i && j_fluid) {
      const float3 r = xi - xj.xyz;
      const float len = length(r), mj = particle_mass(xj);
      xsph += (mj / rho_j) * (v_j - vi) * poly6(K, len * len);
      eta += (mj / rho_j) * (length(omega_j) - length(omega)) * spiky_gradient(K, r);
      const float k = 2 * rho0 / (rho_i + rho_j);
      if (len > 1e-9) accel += k * (-o.fluid.y * mj * cohesion_spline(K, len) * (r / len) - o.fluid.z * (ni - n_j));
    }
  })
  float3 v = vi + o.fluid.x * xsph + dt * accel;
  // eta = grad |omega| points toward stronger vorticity
  const float eta_len = length(eta);
  if (o.fluid.w > 0 && eta_len > 1e-9) v += dt * o.fluid.w * cross(eta / eta_len, omega);
  velocities[i].xyz = v;
}
