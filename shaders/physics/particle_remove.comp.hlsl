// Step start, one thread per particle: fluid particles flagged in control.particle_remove (by
// Engine.remove_particles or a task pass, e.g. suction) become inactive slots: no reallocation,
// particles.emitted drops, and particles.first_free keeps the lowest free slot of each object so
// its emitter reuses the slot. Flags on other particles are ignored; every flag is cleared.
#include "cressim/layout.h"
#include "cressim/particle.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<ParticleObject> objects;
RWStructuredBuffer<uint> remove_flags;
RWStructuredBuffer<uint4> phases;
RWStructuredBuffer<float4> velocities;
RWStructuredBuffer<uint> emitted;
RWStructuredBuffer<uint> first_free;

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint i = id.x;
  if (i >= pc.particle_count || remove_flags[i] == 0) return;
  remove_flags[i] = 0;
  const uint4 ph = phases[i];
  if (ph.x != PARTICLE_FLUID || (ph.w & PARTICLE_ACTIVE) == 0) return;
  phases[i].w = ph.w & ~PARTICLE_ACTIVE;
  velocities[i] = float4(0, 0, 0, 0);
  // sums and minima do not depend on the threads' order: the same slots are reused every run
  InterlockedAdd(emitted[ph.y], 0xffffffffu);
  InterlockedMin(first_free[ph.y], i - objects[ph.y].range.x);
}
