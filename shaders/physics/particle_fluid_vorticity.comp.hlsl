// Fluid velocity terms, step 1: each fluid particle's vorticity omega_i = sum_j V_j grad_i W_ij x (v_j - v_i)
// and its surface normal n_i = h sum_j V_j grad W_ij (Akinci et al. 2013), with V_j = m_j / rho_j;
// the velocities are copied so that step 2 reads them unchanged.
#include "cressim/layout.h"
#include "cressim/particle.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<ParticleObject> objects;
StructuredBuffer<uint4> phases;
StructuredBuffer<float4> positions;
StructuredBuffer<float4> velocities;
StructuredBuffer<float> densities;
RWStructuredBuffer<float4> vorticities;
RWStructuredBuffer<float4> normals;
RWStructuredBuffer<float4> velocity_copies;

#include "particle_neighbor_list.hlsli"
#include "particle_fluid.hlsli"

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint i = id.x;
  if (i >= pc.particle_count) return;
  velocity_copies[i] = velocities[i];
  const uint4 ph = phases[i];
  if (ph.x != PARTICLE_FLUID || (ph.w & PARTICLE_ACTIVE) == 0) return;
  const Kernel K = make_kernel(objects[ph.y].material.x);
  const float3 xi = positions[i].xyz, vi = velocities[i].xyz;
  float3 omega = float3(0, 0, 0), n = float3(0, 0, 0);
  FOR_EACH_NEIGHBOR(i, j, xj, j_fluid, 4, {
    const float rho_j = densities[j];
    const float3 v_j = velocities[j].xyz;
    if (j != i && j_fluid) {
      const float3 g = spiky_gradient(K, xi - xj.xyz);
      const float vj = particle_mass(xj) / max(rho_j, 1e-6);
      omega += vj * cross(g, v_j - vi);
      n += vj * g;
    }
  })
  vorticities[i] = float4(omega, 0);
  normals[i] = float4(K.h * n, 0);
}
