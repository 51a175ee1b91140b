// SoftBodyPush task logic: apply_action a thread an env, evaluate and observe a thread group an
// env (env_group.hlsli). The pusher is
// body `env` (one rigid body per env); the cube is the env's particle range.
#include "cressim/layout.h"

struct Params {
  uint envs;
  uint max_steps;
  uint reset_all;
  float step_length;  // pusher travel per step and unit action (m)
  float target_x, target_y, target_half_x, target_half_y, target_height;
  float success;      // occupancy that ends an episode
  float limit_x, limit_y;  // the pusher stays over the ground
};
[[vk::push_constant]] ConstantBuffer<Params> pc;

StructuredBuffer<float4> particle_positions;  // particles.positions
StructuredBuffer<uint4> particle_env_ranges;  // particles.env_ranges: x first, y count
StructuredBuffer<float4> body_positions;      // rigid.positions
RWStructuredBuffer<float4> target_positions;  // control.body_target_positions
RWStructuredBuffer<float> actions;            // (envs, 2)
RWStructuredBuffer<uint> reset_mask;
RWStructuredBuffer<float> observations;       // (envs, 5)
RWStructuredBuffer<float> rewards;
RWStructuredBuffer<uint> terminated;
RWStructuredBuffer<uint> truncated;
RWStructuredBuffer<uint> episode_length;
RWStructuredBuffer<float> finished_length;

#include "episode.hlsli"
#include "env_group.hlsli"

// centroid (xy) and the fraction of particles inside the target box, summed by the env's group
float3 cube_state(uint env, uint lane) {
  const uint4 r = particle_env_ranges[env];
  float4 sum = float4(0, 0, 0, 0);  // x, y, inside
  for (uint i = r.x + lane; i < r.x + r.y; i += ENV_GROUP) {
    const float3 x = particle_positions[i].xyz;
    sum.xy += x.xy;
    if (abs(x.x - pc.target_x) <= pc.target_half_x && abs(x.y - pc.target_y) <= pc.target_half_y && x.z <= pc.target_height)
      sum.z += 1;
  }
  sum = env_group_sum(sum, lane);
  const float n = max(float(r.y), 1.0);
  return float3(sum.xy / n, sum.z / n);
}

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void apply_action(uint3 id : SV_DispatchThreadID) {
  const uint env = id.x;
  if (env >= pc.envs) return;
  const float2 a = clamp(float2(actions[2 * env], actions[2 * env + 1]), -1.0, 1.0);
  float4 t = target_positions[env];
  t.xy = clamp(body_positions[env].xy + a * pc.step_length, -float2(pc.limit_x, pc.limit_y), float2(pc.limit_x, pc.limit_y));
  target_positions[env] = t;
}

[numthreads(ENV_GROUP, 1, 1)]
void evaluate(uint3 group : SV_GroupID, uint3 thread : SV_GroupThreadID) {
  const uint env = group.x;
  if (env >= pc.envs) return;
  const float3 s = cube_state(env, thread.x);
  if (thread.x != 0) return;
  const float distance = length(s.xy - float2(pc.target_x, pc.target_y));
  const bool success = s.z >= pc.success, failed = reset_mask[env] != 0;  // flagged unhealthy this frame
  rewards[env] = pc.reset_all != 0 ? 0.0 : s.z + 0.25 * max(0.0, 1.0 - 2.0 * distance);
  if (end_step(env, success || failed)) reset_mask[env] = 1;  // the engine puts the cube and the pusher back
}

[numthreads(ENV_GROUP, 1, 1)]
void observe(uint3 group : SV_GroupID, uint3 thread : SV_GroupThreadID) {
  const uint env = group.x;
  if (env >= pc.envs) return;
  const float3 s = cube_state(env, thread.x);
  if (thread.x != 0) return;
  const float3 p = body_positions[env].xyz;
  observations[5 * env + 0] = p.x;
  observations[5 * env + 1] = p.y - pc.target_y;
  observations[5 * env + 2] = s.x;
  observations[5 * env + 3] = s.y - pc.target_y;
  observations[5 * env + 4] = s.z;
}
