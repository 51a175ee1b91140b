// CartPole task logic, one thread per env (entry points apply_action, evaluate, observe).
// Joint rows of each env: task_joints[2 env] slider (cart), task_joints[2 env + 1] hinge (pole).
#include "cressim/layout.h"

struct Params {
  uint envs;
  uint max_steps;      // truncation
  uint seed;
  float action_scale;  // m/s of cart target velocity per unit action
  float max_x;         // termination bounds
  float max_angle;
  float reset_range;   // uniform +-range for x, v, angle, angular velocity at reset
  uint reset_all;      // 1: flag every env (reset())
  uint env_offset;      // env 0's index in the whole batch: a shard draws that batch's numbers (vector_env.py)
};
[[vk::push_constant]] ConstantBuffer<Params> pc;

StructuredBuffer<uint> task_joints;
StructuredBuffer<float> joint_positions;
StructuredBuffer<float> joint_velocities;
StructuredBuffer<uint> reset_count;
RWStructuredBuffer<float> actions;           // (envs, 1)
RWStructuredBuffer<float4> joint_targets;    // control.joint_targets
RWStructuredBuffer<float4> joint_reset;      // control.joint_reset
RWStructuredBuffer<uint> reset_mask;         // env.reset_mask
RWStructuredBuffer<float> observations;      // (envs, 4)
RWStructuredBuffer<float> rewards;
RWStructuredBuffer<uint> terminated;
RWStructuredBuffer<uint> truncated;
RWStructuredBuffer<uint> episode_length;
RWStructuredBuffer<float> finished_length;   // length of the episode that ended this step, else 0

#include "episode.hlsli"

uint pcg_hash(uint v) {
  const uint state = v * 747796405u + 2891336453u;
  const uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
  return (word >> 22u) ^ word;
}
float uniform_pm1(uint env, uint k) {
  const uint h = pcg_hash(pc.seed ^ pcg_hash((env + pc.env_offset) * 4u + k) ^ pcg_hash(reset_count[env] * 7919u + 17u));
  return float(h) * (2.0 / 4294967295.0) - 1.0;
}

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void apply_action(uint3 id : SV_DispatchThreadID) {
  const uint env = id.x;
  if (env >= pc.envs) return;
  const float a = clamp(actions[env], -1.0, 1.0);
  joint_targets[task_joints[2 * env]].x = a * pc.action_scale;
}

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void evaluate(uint3 id : SV_DispatchThreadID) {
  const uint env = id.x;
  if (env >= pc.envs) return;
  const uint slider = task_joints[2 * env], hinge = task_joints[2 * env + 1];
  // out of bounds, or flagged unhealthy (NaN, speed) by the solver this frame
  const bool failed = abs(joint_positions[slider]) > pc.max_x || abs(joint_positions[hinge]) > pc.max_angle ||
                   reset_mask[env] != 0;
  rewards[env] = pc.reset_all != 0 ? 0.0 : 1.0;
  if (!end_step(env, failed)) return;
  // next episode's start: uniform state, applied by the engine's reset (reset_flagged_envs)
  reset_mask[env] = 1;
  joint_reset[slider] = float4(pc.reset_range * uniform_pm1(env, 0), pc.reset_range * uniform_pm1(env, 1), 0, 0);
  joint_reset[hinge] = float4(pc.reset_range * uniform_pm1(env, 2), pc.reset_range * uniform_pm1(env, 3), 0, 0);
  joint_targets[slider].x = 0;
}

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void observe(uint3 id : SV_DispatchThreadID) {
  const uint env = id.x;
  if (env >= pc.envs) return;
  const uint slider = task_joints[2 * env], hinge = task_joints[2 * env + 1];
  observations[4 * env + 0] = joint_positions[slider];
  observations[4 * env + 1] = joint_velocities[slider];
  observations[4 * env + 2] = joint_positions[hinge];
  observations[4 * env + 3] = joint_velocities[hinge];
}
