// Needles of envs flagged in env.reset_mask let go of every puncture and forget the tip's last
// place (the next substep takes it afresh instead of sweeping from where it was).
#include "cressim/layout.h"
#include "cressim/particle.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<NeedleModel> needles;
RWStructuredBuffer<Puncture> punctures;
RWStructuredBuffer<float4> needle_states;
RWStructuredBuffer<float4> needle_threads;
StructuredBuffer<uint> reset_mask;

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  if (id.x >= pc.item_count) return;
  const NeedleModel n = needles[id.x];
  if (reset_mask[n.ids.w] == 0) return;
  for (uint r = n.records.x; r < n.records.x + n.records.y; ++r) punctures[r].ids.x = PUNCTURE_FREE;
  needle_states[id.x] = float4(0, 0, 0, -1);
  needle_threads[id.x] = float4(0, 0, 0, 0);
}
