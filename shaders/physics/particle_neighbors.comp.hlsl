// Per iteration, the corrections that come from neighbours: the fluid density correction
// between fluid particles, Delta x_i = 1/rho0 sum_j m_j (lambda_i + lambda_j) grad W_ij, and
// contacts (overlap of radii, split by inverse mass, averaged over the particle's contacts)
// between particles of different objects, or of one self-colliding object. Each particle
// writes only its own delta. A fluid particle near rigid walls also takes its own multiplier's
// share along the walls' density gradient (the walls do not move), as particle_fluid_lambda left
// it in wall_gradients: the fluid has not moved since.
#include "cressim/layout.h"
#include "cressim/particle.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<ParticleObject> objects;
StructuredBuffer<uint4> phases;
StructuredBuffer<float4> positions;
StructuredBuffer<float> fluid_lambdas;
StructuredBuffer<float4> wall_gradients;
RWStructuredBuffer<float4> deltas;

#include "particle_neighbor_list.hlsli"
#include "particle_fluid.hlsli"
#include "particle_contact.hlsli"

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint i = id.x;
  if (i >= pc.particle_count) return;
  const uint4 ph = phases[i];
  const float4 xi = positions[i];
  if ((ph.w & PARTICLE_ACTIVE) == 0 || xi.w <= 0) {
    deltas[i] = float4(0, 0, 0, 0);
    return;
  }
  const ParticleObject oi = objects[ph.y];
  const bool fluid = ph.x == PARTICLE_FLUID;
  const Kernel K = make_kernel(oi.material.x);
  const float rho0 = oi.material.w, lambda_i = fluid ? fluid_lambdas[i] : 0;
  float3 density_delta = float3(0, 0, 0), contact = float3(0, 0, 0);
  float contacts = 0;
  FOR_EACH_NEIGHBOR(i, j, xj, j_fluid, 1, {
    if (j != i) {
      const float3 r = xi.xyz - xj.xyz;
      const uint4 pj = fluid && j_fluid ? uint4(0, 0, 0, 0) : phases[j];  // the kind is in the entry
      if (fluid && j_fluid) {
        density_delta += density_correction(K, r, xj, lambda_i, fluid_lambdas[j]);
      } else if (particles_collide(i, ph, j, pj)) {
        add_contact(r, oi.material.x + objects[pj.y].material.x, xi.w, xj.w, contact, contacts);
      }
    }
  })
  if (fluid && lambda_i != 0) density_delta += lambda_i * wall_gradients[i].xyz;
  float3 delta = density_delta / max(rho0, 1e-9);
  if (contacts > 0) delta += contact / contacts;
  deltas[i] = float4(delta, 0);
}
