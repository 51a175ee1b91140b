// Frame end, after the heat cycles, and after an env's reset: a thread per tet of a body with heat
// sets the tet's material from its coagulated share f = 1 - exp(-Omega), Omega the mean damage of
// its corners: stiffness (mu, lambda) times 1 + (s - 1) f, and the rest shape shrunk by the linear
// strain e f (Dm^-1 over 1 - e f, the rest volume times its cube), from the authored records; so
// coagulated tissue stiffens and draws together, and a reset env's tets are as authored again.
// At the frame's end a tet without damage is skipped (damage only grows between resets, and the
// run after a reset, item_offset 1, writes every tet): most tets are never heated.
// Where the env's heat source is on in cut mode (heat_sources row 1: y 1), a coagulated tet (f above
// 0.9) whose centre lies within the source's radius is cut (control.particle_tet_cut): the
// energized tool parts the tissue it has coagulated, as an electrosurgical cut leaves coagulated
// edges; in coagulation mode (y 0) it only heats.
#include "cressim/layout.h"
#include "cressim/particle.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
RWStructuredBuffer<ParticleConstraint> constraints;
RWStructuredBuffer<float4> record_rows;
StructuredBuffer<ParticleConstraint> initial_constraints;  // as authored
StructuredBuffer<float4> initial_rows;
RWStructuredBuffer<uint> cut;
StructuredBuffer<uint4> phases;
StructuredBuffer<float4> positions;
StructuredBuffer<ParticleObject> objects;
StructuredBuffer<float> damage;
StructuredBuffer<float4> heat_sources;

static const float CUT_COAGULATED = 0.9;

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint t = id.x;
  if (t >= pc.item_count) return;
  const uint4 q = initial_constraints[t].particles;
  const float omega = 0.25 * (damage[q.x] + damage[q.y] + damage[q.z] + damage[q.w]);
  if (omega == 0 && pc.item_offset == 0) return;  // (a body without heat has no damage either)
  const ParticleObject o = objects[phases[q.x].y];
  if (o.heat.x <= 0) return;
  const ParticleConstraint c0 = initial_constraints[t];
  const float f = 1 - exp(-omega);
  const float stiff = 1 + (o.coagulation.x - 1) * f, shrink = 1 - o.coagulation.y * f;
  ParticleConstraint c = c0;
  c.params.x = c0.params.x * shrink * shrink * shrink;
  c.params.y = c0.params.y * stiff;
  c.params.z = c0.params.z * stiff;
  constraints[t] = c;
  [unroll] for (uint r = 0; r < 3; ++r) record_rows[3 * t + r] = initial_rows[3 * t + r] / shrink;
  const uint env = phases[q.x].z;
  const float4 source = heat_sources[2 * env];
  const float2 mode = heat_sources[2 * env + 1].xy;  // power, cut
  if (f > CUT_COAGULATED && source.w > 0 && mode.x > 0 && mode.y != 0) {
    const float3 centre = 0.25 * (positions[q.x].xyz + positions[q.y].xyz + positions[q.z].xyz + positions[q.w].xyz);
    if (length(centre - source.xyz) < source.w) cut[t] = 1;
  }
}
