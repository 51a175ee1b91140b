// TargetCenter task logic. `act`: one thread per env: the action turns the camera (yaw, pitch),
// the reward comes from the target's projected offset from the image centre, finished episodes
// start again at once (new target and aim), and the kinematic bodies get their targets (the
// physics step puts them there exactly). With final observations (pc.defer_start), `act` leaves
// finished envs at their last aim for the final image, and `start` begins their next episodes
// after it. `observe` (one pass per camera group): one thread per output word: RGB bytes of each
// env's camera layer into observations (envs, H, W, 3) uint8.
#include "cressim/layout.h"
#include "cressim/quat.h"

struct Params {
  uint envs;
  uint max_steps;
  uint seed;
  uint reset_all;        // 1: start every env (reset())
  float action_scale;    // radians of yaw/pitch per unit action per step
  float tan_half_fov;    // normalises the offset: 1 at the image's edge (square images)
  float success;         // normalised distance that counts as centred
  float start_offset;    // radians: the first aim is off the target by up to this in yaw and pitch
  float area_x;          // targets: x uniform in +-area_x, y in [area_y0, area_y1], z = target_z
  float area_y0;
  float area_y1;
  float target_z;
  uint words_per_env;    // observe: output words per env (H W 3 / 4)
  uint first_env;        // observe: the group's first env (layer 0)
  uint group_envs;       // observe: its envs (layers)
  uint pixels;           // observe: H W
  uint defer_start;      // 1: finished envs begin their next episode in `start`, not in `act`
  uint env_offset;      // env 0's index in the whole batch: a shard draws that batch's numbers (vector_env.py)
};
[[vk::push_constant]] ConstantBuffer<Params> pc;

StructuredBuffer<uint> task_bodies;          // (envs, 2): camera body, target body
StructuredBuffer<float4> body_positions;     // rigid.positions (the camera's position)
RWStructuredBuffer<float4> target_positions; // control.body_target_positions
RWStructuredBuffer<float4> target_rotations; // control.body_target_rotations
RWStructuredBuffer<float4> task_state;       // yaw, pitch, previous distance, episodes started
RWStructuredBuffer<float4> task_target;      // target centre
RWStructuredBuffer<float> actions;           // (envs, 2)
RWStructuredBuffer<float> rewards;
RWStructuredBuffer<uint> terminated;
RWStructuredBuffer<uint> truncated;
RWStructuredBuffer<uint> episode_length;
RWStructuredBuffer<float> finished_length;
StructuredBuffer<uint> rgb;  // observe: camera{g}.rgb as RGBA8 words
RWStructuredBuffer<uint> observations;       // (envs, H, W, 3) uint8 as words

uint pcg_hash(uint v) {
  const uint state = v * 747796405u + 2891336453u;
  const uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
  return (word >> 22u) ^ word;
}
float uniform01(uint env, uint episode, uint k) {
  return float(pcg_hash(pc.seed ^ pcg_hash((env + pc.env_offset) * 8u + k) ^ pcg_hash(episode * 7919u + 17u))) / 4294967295.0;
}

// the camera looks along +y at yaw = pitch = 0 (optical x = world x, optical y = world -z);
// yaw turns it about world z (left positive), pitch tilts it down
float4 camera_rotation(float yaw, float pitch) {
  const float4 base = float4(-0.70710678, 0, 0, 0.70710678);
  return normalize(quat_mul(quat_axis_angle(float3(0, 0, 1), yaw), quat_mul(base, quat_axis_angle(float3(1, 0, 0), -pitch))));
}

// the target's distance from the image centre, 1 at the edge; 2 when behind the camera
float offset(float yaw, float pitch, float3 eye, float3 target) {
  const float3 p = quat_unrotate(camera_rotation(yaw, pitch), target - eye);
  if (p.z < 1e-3) return 2;
  return min(length(p.xy / p.z) / pc.tan_half_fov, 2.0);
}

// the next episode: a new target, the camera aimed near it
void begin_episode(uint env, float3 eye, inout float4 s) {
  const uint episode = uint(s.w) + 1;
  const float3 target = float3(pc.area_x * (2 * uniform01(env, episode, 0) - 1),
                               lerp(pc.area_y0, pc.area_y1, uniform01(env, episode, 1)), pc.target_z);
  const float3 v = target - eye;
  s.x = atan2(-v.x, v.y) + pc.start_offset * (2 * uniform01(env, episode, 2) - 1);
  s.y = atan2(-v.z, length(v.xy)) + pc.start_offset * (2 * uniform01(env, episode, 3) - 1);
  s.z = offset(s.x, s.y, eye, target);
  s.w = float(episode);
  task_target[env] = float4(target, 0);
}

// the kinematic bodies' targets: the camera's aim and the target cube
void place_bodies(uint env, float4 s) {
  target_rotations[task_bodies[2 * env]] = camera_rotation(s.x, s.y);
  target_positions[task_bodies[2 * env + 1]] = float4(task_target[env].xyz, 0);
}

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void act(uint3 id : SV_DispatchThreadID) {
  const uint env = id.x;
  if (env >= pc.envs) return;
  const float3 eye = body_positions[task_bodies[2 * env]].xyz;
  float4 s = task_state[env];
  const float3 target = task_target[env].xyz;
  bool done = pc.reset_all != 0;
  if (!done) {
    s.x += clamp(actions[2 * env], -1.0, 1.0) * pc.action_scale;
    s.y = clamp(s.y + clamp(actions[2 * env + 1], -1.0, 1.0) * pc.action_scale, -1.4, 1.4);
    const float d = offset(s.x, s.y, eye, target);
    const bool centred = d <= pc.success;
    const uint steps = episode_length[env] + 1;
    rewards[env] = s.z - d - 0.01 + (centred ? 1.0 : 0.0);
    terminated[env] = centred ? 1 : 0;
    truncated[env] = !centred && steps >= pc.max_steps ? 1 : 0;
    done = centred || steps >= pc.max_steps;
    finished_length[env] = done ? float(steps) : 0.0;
    episode_length[env] = done ? 0 : steps;
    s.z = d;
  } else {
    rewards[env] = 0;
    terminated[env] = 0;
    truncated[env] = 0;
    finished_length[env] = 0;
    episode_length[env] = 0;
  }
  if (done && (pc.reset_all != 0 || pc.defer_start == 0)) begin_episode(env, eye, s);
  task_state[env] = s;
  place_bodies(env, s);
}

// after the final image: the envs that finished this step begin their next episode
[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void start(uint3 id : SV_DispatchThreadID) {
  const uint env = id.x;
  if (env >= pc.envs || finished_length[env] == 0) return;
  float4 s = task_state[env];
  begin_episode(env, body_positions[task_bodies[2 * env]].xyz, s);
  task_state[env] = s;
  place_bodies(env, s);
}

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void observe(uint3 id : SV_DispatchThreadID) {
  const uint w = id.x;
  if (w >= pc.group_envs * pc.words_per_env) return;
  const uint layer = w / pc.words_per_env, first = 4 * (w % pc.words_per_env);
  uint word = 0;
  for (uint k = 0; k < 4; ++k) {
    const uint byte = first + k;
    word |= ((rgb[layer * pc.pixels + byte / 3] >> (8 * (byte % 3))) & 0xffu) << (8 * k);
  }
  observations[pc.first_env * pc.words_per_env + w] = word;
}
