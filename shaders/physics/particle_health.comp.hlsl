// Frame end, one thread group per env: NaN/Inf or a speed beyond the bound flags the env in
// env.health; a flagged env is reset at the next frame and counted in env.health_events. With a
// rigid system the flags add to the rigid solver's (which already counted the env if it flagged it).
#include "cressim/layout.h"
#include "cressim/particle.h"
#include "cressim/rigid.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<ParticleEnvRange> env_ranges;
StructuredBuffer<uint4> phases;
StructuredBuffer<float4> positions;
StructuredBuffer<float4> velocities;
RWStructuredBuffer<uint> health;
RWStructuredBuffer<uint> reset_mask;
RWStructuredBuffer<uint> health_events;

groupshared uint group_flags[PARTICLE_ENV_GROUP];

[numthreads(PARTICLE_ENV_GROUP, 1, 1)]
void main(uint3 group : SV_GroupID, uint lane : SV_GroupIndex) {
  const uint env = group.x;
  if (env >= pc.env_count) return;  // the whole group
  const uint4 r = env_ranges[env].range;
  uint flags = 0;
  for (uint i = r.x + lane; i < r.x + r.y; i += PARTICLE_ENV_GROUP) {
    if ((phases[i].w & PARTICLE_ACTIVE) == 0) continue;
    const float4 x = positions[i], v = velocities[i];
    if (any(isnan(x)) || any(isinf(x)) || any(isnan(v)) || any(isinf(v))) flags |= HEALTH_NAN;
    else if (length(v.xyz) > pc.grid.z) flags |= HEALTH_SPEED;
  }
  group_flags[lane] = flags;
  GroupMemoryBarrierWithGroupSync();
  for (uint half_ = PARTICLE_ENV_GROUP / 2; half_ > 0; half_ /= 2) {
    if (lane < half_) group_flags[lane] |= group_flags[lane + half_];
    GroupMemoryBarrierWithGroupSync();
  }
  if (lane != 0) return;
  flags = group_flags[0];
  const uint before = pc.owns_health != 0 ? 0 : health[env];
  health[env] = before | flags;
  if (flags != 0 && before == 0) {
    reset_mask[env] = 1;
    InterlockedAdd(health_events[0], 1u);
  }
}
