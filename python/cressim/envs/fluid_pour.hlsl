// FluidPour task logic: apply_action a thread an env, evaluate and observe a thread group an env
// (env_group.hlsli). The source
// container is body `env` (one rigid body per env); the fluid is the env's particle range.
#include "cressim/layout.h"
#include "cressim/quat.h"

struct Params {
  uint envs;
  uint max_steps;
  uint reset_all;
  float move_step, tilt_step, max_tilt;  // per step and unit action
  float min_x, max_x;                    // source x range
  float target_x, target_y, target_floor;
  float inner_x, inner_y, inner_height;  // target's inner half extents and height
  float spill_penalty;
  float success;
};
[[vk::push_constant]] ConstantBuffer<Params> pc;

StructuredBuffer<float4> particle_positions;
StructuredBuffer<uint4> particle_env_ranges;
StructuredBuffer<float4> body_positions;
StructuredBuffer<float4> body_rotations;
RWStructuredBuffer<float4> target_positions;
RWStructuredBuffer<float4> target_rotations;
RWStructuredBuffer<float> actions;  // (envs, 2)
RWStructuredBuffer<uint> reset_mask;
RWStructuredBuffer<float> observations;  // (envs, 6)
RWStructuredBuffer<float> rewards;
RWStructuredBuffer<uint> terminated;
RWStructuredBuffer<uint> truncated;
RWStructuredBuffer<uint> episode_length;
RWStructuredBuffer<float> finished_length;

#include "episode.hlsli"
#include "env_group.hlsli"

// tilt about +y (pouring toward +x) of a rotation that has only that
float tilt_of(float4 q) { return 2 * atan2(q.y, q.w); }

struct FluidState {
  float2 mean_xz;  // x, height
  float caught;
  float spilled;
};

// summed by the env's group
FluidState fluid_state(uint env, uint lane) {
  const uint4 r = particle_env_ranges[env];
  float4 sum = float4(0, 0, 0, 0);  // x, height, caught, spilled
  for (uint i = r.x + lane; i < r.x + r.y; i += ENV_GROUP) {
    const float3 x = particle_positions[i].xyz;
    sum.xy += x.xz;
    const bool in_target = abs(x.x - pc.target_x) <= pc.inner_x && abs(x.y - pc.target_y) <= pc.inner_y &&
                           x.z >= pc.target_floor && x.z <= pc.target_floor + pc.inner_height;
    if (in_target) sum.z += 1;
    else if (x.z < pc.target_floor) sum.w += 1;  // on the ground outside the target
  }
  sum = env_group_sum(sum, lane);
  const float n = max(float(r.y), 1.0);
  FluidState s;
  s.mean_xz = sum.xy / n;
  s.caught = sum.z / n;
  s.spilled = sum.w / n;
  return s;
}

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void apply_action(uint3 id : SV_DispatchThreadID) {
  const uint env = id.x;
  if (env >= pc.envs) return;
  const float2 a = clamp(float2(actions[2 * env], actions[2 * env + 1]), -1.0, 1.0);
  float4 t = target_positions[env];
  t.x = clamp(body_positions[env].x + a.x * pc.move_step, pc.min_x, pc.max_x);
  target_positions[env] = t;
  const float tilt = clamp(tilt_of(body_rotations[env]) + a.y * pc.tilt_step, 0.0, pc.max_tilt);
  target_rotations[env] = quat_axis_angle(float3(0, 1, 0), tilt);
}

[numthreads(ENV_GROUP, 1, 1)]
void evaluate(uint3 group : SV_GroupID, uint3 thread : SV_GroupThreadID) {
  const uint env = group.x;
  if (env >= pc.envs) return;
  const FluidState s = fluid_state(env, thread.x);
  if (thread.x != 0) return;
  const bool success = s.caught >= pc.success, failed = reset_mask[env] != 0;
  rewards[env] = pc.reset_all != 0 ? 0.0 : s.caught - pc.spill_penalty * s.spilled;
  if (end_step(env, success || failed)) reset_mask[env] = 1;
}

[numthreads(ENV_GROUP, 1, 1)]
void observe(uint3 group : SV_GroupID, uint3 thread : SV_GroupThreadID) {
  const uint env = group.x;
  if (env >= pc.envs) return;
  const FluidState s = fluid_state(env, thread.x);
  if (thread.x != 0) return;
  observations[6 * env + 0] = body_positions[env].x;
  observations[6 * env + 1] = tilt_of(body_rotations[env]);
  observations[6 * env + 2] = s.mean_xz.x;
  observations[6 * env + 3] = s.mean_xz.y;
  observations[6 * env + 4] = s.caught;
  observations[6 * env + 5] = s.spilled;
}
