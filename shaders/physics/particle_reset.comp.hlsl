// Particles of every env flagged in env.reset_mask go back to their authored state (positions,
// velocities, which budget slots are active, emitter counts, strand frames, temperatures and
// thermal damage); the env's
// attachments are released and its pending removals dropped.
#include "cressim/layout.h"
#include "cressim/particle.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<uint> reset_mask;
StructuredBuffer<float4> initial_positions;
StructuredBuffer<float4> initial_velocities;
StructuredBuffer<uint4> initial_phases;
RWStructuredBuffer<float4> positions;
RWStructuredBuffer<float4> velocities;
RWStructuredBuffer<uint4> phases;
RWStructuredBuffer<ParticleAttachment> attachments;
StructuredBuffer<ParticleObject> objects;
RWStructuredBuffer<uint> emitted;
RWStructuredBuffer<uint> first_free;
RWStructuredBuffer<float> object_supports;
RWStructuredBuffer<uint> remove_flags;
StructuredBuffer<uint> edge_particles;
StructuredBuffer<float4> initial_orientations;
RWStructuredBuffer<float4> orientations;
RWStructuredBuffer<float4> angular_velocities;
RWStructuredBuffer<float> temperatures;  // heat: one-element stand-ins without it (heat.x 0)
RWStructuredBuffer<float> damage;
StructuredBuffer<float> reset_temperatures;

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint i = id.x;
  if (i < pc.attachment_count && reset_mask[attachments[i].ids.w] != 0) attachments[i].ids.z = ATTACH_FREE;
  if (i < pc.item_count && reset_mask[objects[i].range.z] != 0) {
    emitted[i] = objects[i].ids.w;
    first_free[i] = objects[i].ids.w;
    object_supports[i] = 0;
  }
  if (i < pc.edge_count && reset_mask[initial_phases[edge_particles[i]].z] != 0) {
    orientations[i] = initial_orientations[i];
    angular_velocities[i] = float4(0, 0, 0, 0);
  }
  if (i >= pc.particle_count) return;
  const uint4 ph = initial_phases[i];
  if (reset_mask[ph.z] == 0) return;
  positions[i] = initial_positions[i];
  velocities[i] = initial_velocities[i];
  phases[i] = ph;
  remove_flags[i] = 0;
  const float4 heat = objects[ph.y].heat;
  if (heat.x > 0) {
    temperatures[i] = reset_temperatures[i];
    damage[i] = 0;
  }
}
