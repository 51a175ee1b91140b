// TissueRetract task logic, one thread per env: apply_action (joint targets and grasp commands
// from the actions, and the arm's FK inputs), evaluate (scores, ends and restarts episodes),
// observe.
#include "cressim/layout.h"
#include "cressim/quat.h"

struct Params {
  uint envs;
  uint max_steps;
  uint reset_all;
  uint seed;
  uint candidates;     // target_candidates' length
  float target_lift;   // m: the target particle's rise that counts as retracted
  float length_scale;  // m: the reward's distance unit (one unit of the paper's scene)
  float frame;         // s
  float jaw_open;      // rad
  float jaw_closed;    // rad
  uint crtk;           // observations from what a CRTK client knows (tissue_retract.py)
  uint absorbing_success;  // success pays for the steps it leaves (tissue_retract.py)
  uint env_offset;      // env 0's index in the whole batch: a shard draws that batch's numbers (vector_env.py)
};
[[vk::push_constant]] ConstantBuffer<Params> pc;

StructuredBuffer<float4> particle_positions;   // particles.positions
StructuredBuffer<float4> initial_positions;    // particles.initial_positions: the rest shape
StructuredBuffer<uint4> particle_env_ranges;   // particles.env_ranges: x first, y count
StructuredBuffer<float4> body_positions;       // rigid.positions
StructuredBuffer<float4> body_rotations;       // rigid.rotations (xyzw)
StructuredBuffer<uint> tip_bodies;             // per env: the body row that carries the grasp point
StructuredBuffer<float4> grasp_points;         // per env: xyz the grasp point in that body, w reach
RWStructuredBuffer<int4> grasps;               // the Grasp's commands: x closed, y body, z 1 holding, w held
StructuredBuffer<float> arm_start;             // (6): the start joint values
RWStructuredBuffer<float> arm_joints;          // (envs, 12): joint targets, their velocities
StructuredBuffer<float> arm_limits;            // (3, 6): lower and upper joint limits, action scale
RWStructuredBuffer<float> arm_joint_values;    // (envs, 7): the FK pass's input, joints then jaw
StructuredBuffer<float> actions;               // (envs, 7)
StructuredBuffer<uint> target_candidates;      // particles (env-relative) a target is drawn from
// x the target particle (env-relative), y episodes started, z the tip's height when the grasp
// closed (float bits)
RWStructuredBuffer<uint4> task_state;
RWStructuredBuffer<uint> reset_mask;
RWStructuredBuffer<float> observations;        // (envs, 29)
RWStructuredBuffer<float> rewards;
RWStructuredBuffer<uint> terminated;
RWStructuredBuffer<uint> truncated;
RWStructuredBuffer<uint> episode_length;
RWStructuredBuffer<float> finished_length;

#include "episode.hlsli"
#include "arm_action.hlsli"

static const uint OBS = 29;

uint pcg_hash(uint v) {
  const uint state = v * 747796405u + 2891336453u;
  const uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
  return (word >> 22u) ^ word;
}

float3 tip_position(uint env) {
  const uint b = tip_bodies[env];
  return body_positions[b].xyz + quat_rotate(body_rotations[b], grasp_points[env].xyz);
}

uint target_particle(uint env) { return particle_env_ranges[env].x + task_state[env].x; }

// the target particle's rise over its rest height / the target lift, in [0, 1]; 0 unless held
float lift(uint env, bool attached) {
  const uint p = target_particle(env);
  return attached ? saturate((particle_positions[p].z - initial_positions[p].z) / pc.target_lift) : 0.0;
}

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void apply_action(uint3 id : SV_DispatchThreadID) {
  const uint env = id.x;
  if (env >= pc.envs) return;
  for (uint k = 0; k < 6; ++k) {
    const float q = arm_joints[12 * env + k];
    const float target = joint_target(q, action(env, k, 7), k, 6);
    arm_joints[12 * env + 6 + k] = (target - q) / pc.frame;
    arm_joints[12 * env + k] = target;
    arm_joint_values[7 * env + k] = target;
  }
  const float grasp = action(env, 6, 7);
  int4 g = grasps[env];
  const int closed = grasp > 0 ? 1 : (grasp < 0 ? 0 : g.x);
  if (closed != 0 && g.x == 0) task_state[env].z = asuint(tip_position(env).z);  // where the lift counts from
  g.x = closed;
  grasps[env] = g;
  arm_joint_values[7 * env + 6] = g.x != 0 ? pc.jaw_closed : pc.jaw_open;
}

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void evaluate(uint3 id : SV_DispatchThreadID) {
  const uint env = id.x;
  if (env >= pc.envs) return;
  const bool attached = grasps[env].z == 1;
  const float l = lift(env, attached);
  const float distance = length(tip_position(env) - particle_positions[target_particle(env)].xyz);
  const bool success = attached && l >= 1.0, failed = reset_mask[env] != 0;  // flagged unhealthy this frame
  const float reward = -distance / pc.length_scale + 0.5 * float(attached) + 4.0 * l;
  // absorbing success: the success step's reward for each step left before the time limit too
  const float left = success && pc.absorbing_success != 0 ? float(pc.max_steps - 1 - episode_length[env]) : 0.0;
  rewards[env] = pc.reset_all != 0 ? 0.0 : reward * (1.0 + left);
  if (!end_step(env, success || failed)) return;
  reset_mask[env] = 1;  // the engine puts the tissue and the arm's bodies back and frees the attachments
  for (uint k = 0; k < 6; ++k) {
    arm_joints[12 * env + k] = arm_start[k];
    arm_joints[12 * env + 6 + k] = 0.0;
  }
  grasps[env] = int4(0, grasps[env].y, 0, 0);  // open
  uint4 s = task_state[env];
  s.y = pc.reset_all != 0 ? 0 : s.y + 1;
  s.x = target_candidates[pcg_hash(pc.seed ^ pcg_hash(env + pc.env_offset) ^ pcg_hash(s.y * 7919u + 17u)) % pc.candidates];
  task_state[env] = s;
}

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void observe(uint3 id : SV_DispatchThreadID) {
  const uint env = id.x;
  if (env >= pc.envs) return;
  const uint o = OBS * env;
  for (uint k = 0; k < 12; ++k) observations[o + k] = arm_joints[12 * env + k];
  const uint p = target_particle(env);
  const float3 tip = tip_position(env);
  const float4 r = body_rotations[tip_bodies[env]];
  const float3 x_axis = quat_rotate(r, float3(1, 0, 0)), y_axis = quat_rotate(r, float3(0, 1, 0));
  float3 target;
  float grasp, lifted;
  if (pc.crtk != 0) {  // the target's rest position, the commanded grasp, the tip's rise since it closed
    target = initial_positions[p].xyz;
    grasp = float(grasps[env].x != 0);
    lifted = grasp * saturate((tip.z - asfloat(task_state[env].z)) / pc.target_lift);
  } else {
    target = particle_positions[p].xyz;
    const bool attached = grasps[env].z == 1;
    grasp = float(attached);
    lifted = lift(env, attached);
  }
  const float values[17] = {target.x, target.y, target.z, tip.x, tip.y, tip.z, x_axis.x, x_axis.y, x_axis.z,
                            y_axis.x, y_axis.y, y_axis.z, target.x - tip.x, target.y - tip.y, target.z - tip.z,
                            grasp, lifted};
  for (uint i = 0; i < 17; ++i) observations[o + 12 + i] = values[i];
}
