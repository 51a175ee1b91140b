// Env reset for one constraint family: the constraints of every env flagged in env.reset_mask
// are whole again (their cut flags cleared). A record's env is its first particle's, or for a
// frame id (particle_count + segment) that segment's first particle's.
#include "cressim/layout.h"
#include "cressim/particle.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<uint> reset_mask;
StructuredBuffer<ParticleConstraint> constraints;
StructuredBuffer<uint4> initial_phases;
StructuredBuffer<uint> edge_particles;
RWStructuredBuffer<uint> cut;

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint c = id.x;
  if (c >= pc.item_count) return;
  uint p = constraints[c].particles.x;
  if (p >= pc.particle_count) p = edge_particles[p - pc.particle_count];
  if (reset_mask[initial_phases[p].z] != 0) cut[c] = 0;
}
