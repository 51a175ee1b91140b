// Heat, step 2 of 2: each particle with heat advances its temperature by its rate over the heat
// cycle's step (explicit: the cycles per frame keep the step within the conduction's stability
// limit, ParticleModel::heat_step_limit) and its thermal damage by the Arrhenius integral,
//   dOmega/dt = A exp(-Ea / (R T)),
// at the cycle's starting temperature, above the damage onset (the fit is for hyperthermia: carried
// down to 37 C it would coagulate resting tissue in an hour). Omega 1 is the usual threshold of
// coagulation (63 % of the tissue's proteins denatured).
#include "cressim/layout.h"
#include "cressim/particle.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<uint4> phases;
StructuredBuffer<ParticleObject> objects;
StructuredBuffer<float> heat_capacities;
StructuredBuffer<float> heat_rates;
RWStructuredBuffer<float> temperatures;
RWStructuredBuffer<float> damage;

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint i = id.x;
  if (i >= pc.particle_count || heat_capacities[i] <= 0) return;
  const float dt = pc.gravity.w * pc.grid.w / max(pc.item_count, 1u);  // the frame over the cycles
  const float4 burn = objects[phases[i].y].burn;
  const float T = temperatures[i];
  if (T > burn.z) damage[i] += dt * exp(min(burn.x - burn.y / T, 80.0));  // exp(80): beyond any use, short of inf
  temperatures[i] = T + dt * heat_rates[i];
}
