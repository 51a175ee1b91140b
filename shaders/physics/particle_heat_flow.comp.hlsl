// Heat, step 1 of 2 (once per heat cycle, a few per frame at most): each particle of an elastic
// body with heat (ParticleObject.heat.x, its conductivity, > 0) gets its rate of temperature change
//   C_i dT_i/dt = - sum over its tets, other corners j of  k V0 (b_i . b_j) (T_j - T_i)  +  q_i
// (linear tets, lumped heat capacity C_i = m_i c: the conductance matrix K_ij = k V0 b_i . b_j has
// rows that sum to 0, so only differences flow and heat is conserved), where q_i is the share of
// the env's heat source's power P (control.heat_sources: a point, radius R, power P) that the
// particle's volume V_i = m_i / rho takes of all the tissue within R (particle_heat_cover):
// P V_i / V_covered. The source delivers P wherever it touches tissue, none in air. The
// temperatures are all read before any is written (particle_heat_apply), so the threads do not
// race.
#include "cressim/layout.h"
#include "cressim/particle.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<ParticleConstraint> constraints;  // tets: particles; params x V0
StructuredBuffer<float4> record_rows;              // Dm^-1, 3 rows a tet
StructuredBuffer<uint> cut;
StructuredBuffer<uint> vertices;
StructuredBuffer<uint2> vertex_records;
StructuredBuffer<uint> vertex_corners;
StructuredBuffer<uint4> phases;
StructuredBuffer<float4> positions;
StructuredBuffer<ParticleObject> objects;
StructuredBuffer<float> heat_capacities;  // m c per particle (J/K; 0: no heat)
StructuredBuffer<float> temperatures;
StructuredBuffer<float4> heat_sources;    // per env: (point xyz, radius w), (power W, cut mode, -, -)
StructuredBuffer<float> heat_cover;       // per env: the tissue volume within the source's radius
RWStructuredBuffer<float> heat_rates;     // K/s


[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  if (id.x >= pc.item_count) return;  // item_count: the tets' solved particles
  const uint v = id.x, i = vertices[v];
  const float capacity = heat_capacities[i];
  if (capacity <= 0) return;
  const uint4 ph = phases[i];
  const ParticleObject o = objects[ph.y];
  const float Ti = temperatures[i];
  float power = 0;
  const uint2 range = vertex_records[v];
  for (uint n = 0; n < range.y; ++n) {
    const uint rc = vertex_corners[range.x + n], t = rc >> 2, k = rc & 3;
    if (cut[t] != 0) continue;
    const ParticleConstraint c = constraints[t];
    // b_k: row k - 1 of Dm^-1, b_0 minus their sum (each tet's rows loaded once)
    const float3 r0 = record_rows[3 * t].xyz, r1 = record_rows[3 * t + 1].xyz, r2 = record_rows[3 * t + 2].xyz;
    const float3 b[4] = {-(r0 + r1 + r2), r0, r1, r2};
    const uint q[4] = {c.particles.x, c.particles.y, c.particles.z, c.particles.w};
    const float kv = o.heat.x * c.params.x;
    [unroll] for (uint j = 0; j < 4; ++j)
      if (j != k) power -= kv * dot(b[k], b[j]) * (temperatures[q[j]] - Ti);
  }
  const float4 at = heat_sources[2 * ph.z];
  const float covered = heat_cover[ph.z];
  if (at.w > 0 && covered > 0 && length(positions[i].xyz - at.xyz) < at.w)
    power += heat_sources[2 * ph.z + 1].x * capacity / (o.heat.y * o.heat.w) / covered;
  heat_rates[i] = power / capacity;
}
