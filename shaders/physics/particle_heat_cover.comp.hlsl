// Heat, before a frame's heat cycles, one thread per env: the volume of tissue with heat within its
// heat source's radius (sum of m_i / rho over those particles), so that the source's power goes
// into that tissue whatever share of its sphere the tissue fills: an electrode's current flows
// through the tissue it touches, not the air around it (particle_heat_flow.comp.hlsl).
#include "cressim/layout.h"
#include "cressim/particle.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<ParticleEnvRange> env_ranges;
StructuredBuffer<uint4> phases;
StructuredBuffer<float4> positions;
StructuredBuffer<ParticleObject> objects;
StructuredBuffer<float> heat_capacities;
StructuredBuffer<float4> heat_sources;
RWStructuredBuffer<float> heat_cover;  // m^3 per env

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint env = id.x;
  if (env >= pc.env_count) return;
  const float4 at = heat_sources[2 * env];
  float volume = 0;
  if (at.w > 0 && heat_sources[2 * env + 1].x > 0) {
    const uint4 r = env_ranges[env].range;
    for (uint i = r.x; i < r.x + r.y; ++i) {
      const float capacity = heat_capacities[i];
      if (capacity <= 0 || length(positions[i].xyz - at.xyz) >= at.w) continue;
      const float4 heat = objects[phases[i].y].heat;
      volume += capacity / (heat.y * heat.w);
    }
  }
  heat_cover[env] = volume;
}
