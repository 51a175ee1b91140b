// BloodSuction task logic (blood_suction.py). `apply_action`, `evaluate` and `observe`: one
// thread per env; `observe_image` (one pass per camera group): one thread per image value.
// apply_action steps the arm's joint targets and the valve (and writes the arm's FK input), the
// Suction pass removes and counts the blood within reach; evaluate scores, ends and restarts
// episodes, observe writes the observations.
#include "cressim/layout.h"
#include "cressim/particle.h"
#include "cressim/quat.h"

struct Params {
  uint envs;
  uint max_steps;
  uint reset_all;
  uint fluid_offset;     // env-relative index of the first blood particle
  uint fluid_count;      // blood particles per env
  uint clear_count;      // removed particles that clear the field (success)
  uint absorbing_success;  // success also pays for the blood left (blood_suction.py)
  float success_reward;  // paid on the step the field clears
  uint seed;             // the start draws' seed
  float start_spread;    // rad: each episode's start yaw and pitch within +- this of arm_start's
  float removal_reward;  // per particle removed
  float length_scale;    // m: the progress reward's distance unit (one unit of the paper's scene)
  uint row;              // observation values per env (NUMBERS + image)
  uint first_env;        // observe_image: the camera group's first env (layer 0)
  uint group_envs;       // observe_image: its envs (layers)
  uint pixels;           // observe_image: H W
  uint final_obs;        // observe: 1 in the pass that writes the final observations (before evaluate)
  uint env_offset;      // env 0's index in the whole batch: a shard draws that batch's numbers (vector_env.py)
};
[[vk::push_constant]] ConstantBuffer<Params> pc;

StructuredBuffer<float4> particle_positions;   // particles.positions
StructuredBuffer<uint4> particle_phases;       // particles.phases: w flags (PARTICLE_ACTIVE)
StructuredBuffer<uint4> particle_env_ranges;   // particles.env_ranges: x first, y count
// the arm's kinematic bodies where the FK pass put them (control.body_target_*): where they are
// after a step, and after a reset where the episode's drawn start puts them
StructuredBuffer<float4> body_positions;
StructuredBuffer<float4> body_rotations;       // xyzw
StructuredBuffer<uint> tip_bodies;             // per env: the suction tube's body row
StructuredBuffer<float4> suction_tips;         // per env: xyz the tip in that body, w the radius
RWStructuredBuffer<int4> suctions;             // the Suction's commands: x on, y body, w removed so far
StructuredBuffer<float> arm_start;             // (4): the start joint values
RWStructuredBuffer<float> arm_joints;          // (envs, 4): joint targets
StructuredBuffer<float> arm_limits;            // (3, 4): lower and upper joint limits, action scale
RWStructuredBuffer<float> arm_joint_values;    // (envs, 5): the FK pass's input, joints then the jaw (0)
StructuredBuffer<float> actions;               // (envs, 5)
// (envs, 2): the aim at the last observation: the nearest active blood particle's position (w 1;
// 0: none left) and the tip's
RWStructuredBuffer<float4> task_aim;
RWStructuredBuffer<uint2> task_state;          // (envs): x removals already rewarded, y episodes begun
RWStructuredBuffer<uint> reset_mask;
RWStructuredBuffer<float> observations;        // (envs, row)
RWStructuredBuffer<float> rewards;
RWStructuredBuffer<uint> terminated;
RWStructuredBuffer<uint> truncated;
RWStructuredBuffer<uint> episode_length;
RWStructuredBuffer<float> finished_length;
StructuredBuffer<uint> rgb;                    // observe_image: camera{g}.rgb as RGBA8 words

#include "episode.hlsli"
#include "arm_action.hlsli"

static const uint NUMBERS = 13;

uint pcg_hash(uint v) {
  const uint state = v * 747796405u + 2891336453u;
  const uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
  return (word >> 22u) ^ word;
}

// in [-1, 1): the draw `k` of the env's episode `episode`
float start_draw(uint env, uint episode, uint k) {
  return float(pcg_hash(pc.seed ^ pcg_hash(env + pc.env_offset) ^ pcg_hash(episode * 7919u + 17u + k * 104729u)) >> 8) / 8388608.0 - 1.0;
}

float3 tip_position(uint env) {
  const uint b = tip_bodies[env];
  return body_positions[b].xyz + quat_rotate(body_rotations[b], suction_tips[env].xyz);
}

uint blood_particle(uint env, uint k) { return particle_env_ranges[env].x + pc.fluid_offset + k; }

bool active(uint p) { return (particle_phases[p].w & PARTICLE_ACTIVE) != 0; }

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void apply_action(uint3 id : SV_DispatchThreadID) {
  const uint env = id.x;
  if (env >= pc.envs) return;
  for (uint k = 0; k < 4; ++k) {
    const float target = joint_target(arm_joints[4 * env + k], action(env, k, 5), k, 4);
    arm_joints[4 * env + k] = target;
    arm_joint_values[5 * env + k] = target;
  }
  arm_joint_values[5 * env + 4] = 0.0;
  suctions[env].x = action(env, 4, 5) >= 0 ? 1 : 0;
}

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void evaluate(uint3 id : SV_DispatchThreadID) {
  const uint env = id.x;
  if (env >= pc.envs) return;
  const uint removed = uint(suctions[env].w);
  // progress: how much nearer the tip came to where the nearest particle was when observed
  // (blood that flows or is sucked away does not count)
  const float4 target = task_aim[2 * env];
  const float3 before = task_aim[2 * env + 1].xyz;
  const float progress = target.w == 0 ? 0.0 : length(target.xyz - before) - length(target.xyz - tip_position(env));
  const bool cleared = removed >= pc.clear_count, failed = reset_mask[env] != 0;  // flagged unhealthy
  // absorbing success: the blood still in the basin is paid as if it were removed too
  const float left = cleared && pc.absorbing_success != 0 ? float(pc.fluid_count - min(removed, pc.fluid_count)) : 0.0;
  const float reward = pc.removal_reward * (float(removed - task_state[env].x) + left) + progress / pc.length_scale +
                       (cleared ? pc.success_reward : 0.0);
  rewards[env] = pc.reset_all != 0 ? 0.0 : reward;
  task_state[env].x = removed;
  if (!end_step(env, cleared || failed)) return;
  reset_mask[env] = 1;  // the engine puts the blood, the basin and the arm's bodies back
  const uint episode = pc.reset_all != 0 ? 0 : task_state[env].y + 1;
  for (uint k = 0; k < 4; ++k) arm_joints[4 * env + k] = arm_start[k];
  arm_joints[4 * env] += pc.start_spread * start_draw(env, episode, 0);  // yaw
  arm_joints[4 * env + 1] += pc.start_spread * start_draw(env, episode, 1);  // pitch
  for (uint k = 0; k < 4; ++k) arm_joint_values[5 * env + k] = arm_joints[4 * env + k];  // sense() poses it
  suctions[env].w = 0;
  task_state[env] = uint2(0, episode);
}

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void observe(uint3 id : SV_DispatchThreadID) {
  const uint env = id.x;
  if (env >= pc.envs) return;
  const float3 tip = tip_position(env);
  float4 nearest = float4(0, 0, 0, 0);
  float best = 1e30;
  for (uint k = 0; k < pc.fluid_count; ++k) {
    const uint p = blood_particle(env, k);
    const float3 x = particle_positions[p].xyz;
    const float d = length(x - tip);
    if (d < best && active(p)) {
      best = d;
      nearest = float4(x, 1);
    }
  }
  const bool final_obs = pc.final_obs != 0;  // before evaluate: leave the reward's aim as it was
  if (!final_obs) {
    task_aim[2 * env] = nearest;
    task_aim[2 * env + 1] = float4(tip, 0);
  }
  const float3 offset = nearest.w == 0 ? float3(0, 0, 0) : nearest.xyz - tip;
  const int4 suction = suctions[env];
  const uint o = pc.row * env;
  for (uint j = 0; j < 4; ++j) observations[o + j] = arm_joints[4 * env + j];
  const float values[9] = {tip.x, tip.y, tip.z, offset.x, offset.y, offset.z,
                           float(suction.w) / float(pc.fluid_count), float(suction.x != 0),
                           float(episode_length[env] + (final_obs ? 1 : 0)) / float(pc.max_steps)};
  for (uint i = 0; i < 9; ++i) observations[o + 4 + i] = values[i];
}

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void observe_image(uint3 id : SV_DispatchThreadID) {
  const uint i = id.x, values = 3 * pc.pixels;
  if (i >= pc.group_envs * values) return;
  const uint layer = i / values, v = i % values;
  const uint word = rgb[layer * pc.pixels + v / 3];
  observations[(pc.first_env + layer) * pc.row + NUMBERS + v] = float((word >> (8 * (v % 3))) & 0xffu) / 255.0;
}
