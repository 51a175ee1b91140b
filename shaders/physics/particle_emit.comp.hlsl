// Frame start, one thread per object: a fluid's emitter activates up to its rate of inactive
// slots (no reallocation), on a square nozzle across the emission direction, with the emission
// velocity. particles.emitted counts each object's active slots; particles.first_free is the
// lowest slot that may be inactive (slots removed at run time leave holes below the others, and
// are filled first, lowest first).
#include "cressim/layout.h"
#include "cressim/particle.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<ParticleObject> objects;
RWStructuredBuffer<uint> emitted;
RWStructuredBuffer<uint> first_free;
RWStructuredBuffer<float4> positions;
RWStructuredBuffer<float4> velocities;
RWStructuredBuffer<uint4> phases;

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint o = id.x;
  if (o >= pc.item_count) return;
  const ParticleObject obj = objects[o];
  const uint rate = uint(obj.emitter.w), budget = obj.ids.z;
  if (rate == 0 || emitted[o] >= budget) return;
  const uint width = max(uint(obj.emit_velocity.w), 1u);
  const float3 v = obj.emit_velocity.xyz, dir = normalize(v);
  // two directions across the nozzle
  const float3 a = normalize(cross(dir, abs(dir.z) < 0.9 ? float3(0, 0, 1) : float3(1, 0, 0)));
  const float3 b = cross(dir, a);
  const float spacing = 2 * obj.material.x;
  uint n = 0, k = first_free[o];
  for (; k < budget && n < rate; ++k) {
    const uint i = obj.range.x + k;
    if ((phases[i].w & PARTICLE_ACTIVE) != 0) continue;
    const uint col = n % width, row = (n / width) % width, layer = n / (width * width);
    const float3 x = obj.emitter.xyz + spacing * ((float(col) - 0.5 * float(width - 1)) * a +
                                                  (float(row) - 0.5 * float(width - 1)) * b - float(layer) * dir);
    positions[i].xyz = x;
    velocities[i] = float4(v, 0);
    phases[i].w |= PARTICLE_ACTIVE;
    ++n;
  }
  first_free[o] = k;  // every slot below k is active now
  emitted[o] += n;
}
