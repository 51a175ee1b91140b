// The workgroup solve's records (the layout is beside PARTICLE_BLOCK_NONE in cressim/particle.h), refreshed at the
// start of every frame from the records as they are now: randomization rewrites compliances and
// cutting flips flags between frames. Their particle indices never change and are left alone.
#include "cressim/layout.h"
#include "cressim/particle.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<ParticleConstraint> constraints;
StructuredBuffer<uint> cut;
RWStructuredBuffer<uint4> block_records;

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint c = id.x;
  if (c >= pc.item_count) return;
  const float4 params = constraints[c].params;
  block_records[c].zw = uint2(asuint(params.x), asuint(cut[c] != 0 ? -1.0 : params.y));
}
