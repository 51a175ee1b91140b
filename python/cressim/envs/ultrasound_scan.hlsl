// UltrasoundScan task logic. One thread per env (apply_action, evaluate); observe runs one
// thread per (env, pixel). task_rows[env] = (probe entity row, the tissue's centre particle (the
// target, carried by the deforming tissue), probe body).
#include "cressim/layout.h"
#include "cressim/quat.h"

struct Params {
  uint envs;
  uint max_steps;
  uint seed;           // (starts are drawn per env at build time)
  float step;          // probe move per unit action (scene units)
  float limit;         // offsets clamped to +-limit
  float half_width;    // image half width and line length: the target's distance from the
  float line_length;   // image centre is normalised by them
  float success;       // normalised distance that counts as centred
  uint pixels;         // H * W of one image
  uint frames;         // stacked frames
  uint reset_all;
  uint final_obs;      // observe: 1 in the pass that writes the final observations (before evaluate)
};
[[vk::push_constant]] ConstantBuffer<Params> pc;

StructuredBuffer<uint4> task_rows;
StructuredBuffer<float4> positions;           // transform.positions
StructuredBuffer<float4> rotations;           // transform.rotations
StructuredBuffer<float4> initial_positions;   // transform.initial_positions
StructuredBuffer<float4> particles;           // particles.positions
StructuredBuffer<float> image;                // ultrasound0.image, layer = env
RWStructuredBuffer<float> actions;            // (envs, 2): lateral, depth
RWStructuredBuffer<float2> probe_offset;      // lateral, depth (along the beam) from the start
RWStructuredBuffer<float> prev_distance;
RWStructuredBuffer<float4> body_targets;      // control.body_target_positions
RWStructuredBuffer<uint> reset_mask;
RWStructuredBuffer<float> observations;       // (envs, frames, H, W)
StructuredBuffer<float> last_observations;    // the last step's observations (the final pass's stack)
RWStructuredBuffer<float> rewards;
RWStructuredBuffer<uint> terminated;
RWStructuredBuffer<uint> truncated;
RWStructuredBuffer<uint> episode_length;
RWStructuredBuffer<float> finished_length;

#include "episode.hlsli"

// the dark target (the tissue's centre) in the probe's image, 0 at the image centre
float target_distance(uint env) {
  const uint4 r = task_rows[env];
  const float3 local = quat_unrotate(rotations[r.x], particles[r.y].xyz - positions[r.x].xyz);
  const float half_depth = 0.5 * pc.line_length;
  return length(float2(local.x / pc.half_width, (local.z - half_depth) / half_depth));
}

// the probe looks down (its +z is the world's -z): depth moves lower it
[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void apply_action(uint3 id : SV_DispatchThreadID) {
  const uint env = id.x;
  if (env >= pc.envs) return;
  const float2 a = clamp(float2(actions[2 * env], actions[2 * env + 1]), -1.0, 1.0);
  const float2 offset = clamp(probe_offset[env] + a * pc.step, -pc.limit, pc.limit);
  probe_offset[env] = offset;
  const uint4 r = task_rows[env];
  body_targets[r.z] = initial_positions[r.x] + float4(offset.x, 0, -offset.y, 0);
}

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void evaluate(uint3 id : SV_DispatchThreadID) {
  const uint env = id.x;
  if (env >= pc.envs) return;
  const float d = target_distance(env);
  const bool centred = d <= pc.success;
  const bool failed = reset_mask[env] != 0;  // flagged unhealthy by the solver
  rewards[env] = pc.reset_all != 0 ? 0.0 : prev_distance[env] - d - 0.01 + (centred ? 1.0 : 0.0);
  if (!end_step(env, centred || failed)) return;
  reset_mask[env] = 1;  // the probe goes back to its start (the engine's reset)
  probe_offset[env] = float2(0, 0);
}

// stacks the image: a new episode fills every frame, otherwise the frames shift by one
[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void observe(uint3 id : SV_DispatchThreadID) {
  const uint env = id.x / pc.pixels, pixel = id.x % pc.pixels;
  if (env >= pc.envs) return;
  const float now = image[env * pc.pixels + pixel];
  const uint base = env * pc.frames * pc.pixels + pixel;
  // the final pass runs before evaluate: it continues the episode's stack and leaves the reward's state
  const bool final_obs = pc.final_obs != 0, fresh = !final_obs && episode_length[env] == 0;
  for (uint f = 0; f + 1 < pc.frames; ++f) {
    const uint older = base + (f + 1) * pc.pixels;
    observations[base + f * pc.pixels] = fresh ? now : final_obs ? last_observations[older] : observations[older];
  }
  observations[base + (pc.frames - 1) * pc.pixels] = now;
  if (pixel == 0 && !final_obs) prev_distance[env] = target_distance(env);
}
