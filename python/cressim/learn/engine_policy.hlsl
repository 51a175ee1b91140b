// A Gaussian MLP policy's step inside the engine's frame (engine_policy.py): the forward pass of
// the torch actor on each env's observation, exploration noise drawn from a per-env hash, the
// action written for the task and the step stored in the rollout. engine_policy.py prepends the
// network's shape (OBS, ACTIONS, LAYERS, WIDTHS, MAX_WIDTH, ENV_TILE, ACTIVATION, NORMALIZED).
//
// One group computes ENV_TILE envs together, layer by layer, the activations in groupshared
// memory: each thread owns output units and reads each weight once for the whole tile (a layer
// narrower than the group, such as the means, gets a thread per unit and env).

struct Params {
  uint envs;
  uint rollout;     // rows of the rollout buffers; an env's step t goes to row t % rollout
  uint seed;
  uint env_offset;  // env 0's index in the whole batch (a shard draws that batch's noise)
  uint explore;     // 0: the mean action (evaluation), 1: mean + std * N(0, 1)
};
[[vk::push_constant]] ConstantBuffer<Params> pc;

// torch's parameters as they lie in memory: [obs mean (OBS), obs var (OBS)] when NORMALIZED,
// then per layer weight (out, in) row-major and bias (out), then log_std (ACTIONS)
StructuredBuffer<float> weights;
StructuredBuffer<float> observations;     // the task's (envs, OBS)
RWStructuredBuffer<float> actions;        // the task's (envs, ACTIONS)
RWStructuredBuffer<float> rollout_obs;    // (rollout, envs, OBS)
RWStructuredBuffer<float> rollout_actions;  // (rollout, envs, ACTIONS)
RWStructuredBuffer<float> rollout_log_prob; // (rollout, envs)
RWStructuredBuffer<uint> rollout_step;    // (envs) steps taken so far, advanced by the store pass

#include "policy_noise.hlsli"

static const uint GROUP = 128;  // every Vulkan device runs 128 invocations a group
static const uint TILE_FLOATS = ENV_TILE * MAX_WIDTH;
groupshared float hidden[2 * TILE_FLOATS];  // ping-pong: layer l reads half l % 2, writes the other

float activate(float x) {
#if ACTIVATION == 0
  // not the intrinsic: drivers may lower it to a fast approximation (2^-11 relative on NVIDIA's
  // tanh.approx), and the pass should give torch's actions to float precision
  return 1.0 - 2.0 / (exp(2.0 * x) + 1.0);
#elif ACTIVATION == 1
  return x > 0.0 ? x : exp(x) - 1.0;  // elu, alpha 1
#else
  return max(x, 0.0);  // relu
#endif
}

[numthreads(GROUP, 1, 1)]
void act(uint3 group_id : SV_GroupID, uint3 thread_id : SV_GroupThreadID) {
  const uint tid = thread_id.x, env0 = group_id.x * ENV_TILE;
  uint w = NORMALIZED ? 2 * OBS : 0;  // where the first layer's weights start

  // the tile's observations (normalised as the torch module does), stored as the rollout's
  for (uint i = tid; i < ENV_TILE * OBS; i += GROUP) {
    const uint e = i / OBS, k = i % OBS, env = env0 + e;
    float x = 0.0;
    if (env < pc.envs) {
      x = observations[env * OBS + k];
      rollout_obs[((rollout_step[env] % pc.rollout) * pc.envs + env) * OBS + k] = x;
#if NORMALIZED
      x = clamp((x - weights[k]) / sqrt(weights[OBS + k] + 1e-8), -10.0, 10.0);
#endif
    }
    hidden[e * MAX_WIDTH + k] = x;
  }
  GroupMemoryBarrierWithGroupSync();

  [unroll] for (uint l = 0; l < LAYERS; ++l) {
    const uint fan_in = WIDTHS[l], fan_out = WIDTHS[l + 1];
    const uint src = (l % 2) * TILE_FLOATS, dst = TILE_FLOATS - src;
    if (fan_out * ENV_TILE <= GROUP) {  // a narrow layer (the means): a thread per (unit, env)
      if (tid < fan_out * ENV_TILE) {
        const uint j = tid % fan_out, e = tid / fan_out;
        float acc = weights[w + fan_out * fan_in + j];
        for (uint k = 0; k < fan_in; ++k) acc += weights[w + j * fan_in + k] * hidden[src + e * MAX_WIDTH + k];
        hidden[dst + e * MAX_WIDTH + j] = l + 1 < LAYERS ? activate(acc) : acc;
      }
    } else for (uint j = tid; j < fan_out; j += GROUP) {  // a thread per unit, each weight read once a tile
      float acc[ENV_TILE];
      const float bias = weights[w + fan_out * fan_in + j];
      [unroll] for (uint e = 0; e < ENV_TILE; ++e) acc[e] = bias;
      for (uint k = 0; k < fan_in; ++k) {
        const float weight = weights[w + j * fan_in + k];
        [unroll] for (uint e = 0; e < ENV_TILE; ++e) acc[e] += weight * hidden[src + e * MAX_WIDTH + k];
      }
      [unroll] for (uint e = 0; e < ENV_TILE; ++e)
        hidden[dst + e * MAX_WIDTH + j] = l + 1 < LAYERS ? activate(acc[e]) : acc[e];
    }
    w += fan_out * fan_in + fan_out;
    GroupMemoryBarrierWithGroupSync();
  }

  // the means are in half LAYERS % 2; log_std follows the last layer's bias
  const uint means = (LAYERS % 2) * TILE_FLOATS;
  if (tid < ENV_TILE && env0 + tid < pc.envs) {
    const uint env = env0 + tid, step = rollout_step[env], row = (step % pc.rollout) * pc.envs + env;
    float log_prob = 0.0;
    for (uint a = 0; a < ACTIONS; ++a) {
      const float log_std = weights[w + a];
      const float z = pc.explore != 0 ? gaussian(pc.seed, env + pc.env_offset, step, a) : 0.0;
      const float action = hidden[means + tid * MAX_WIDTH + a] + exp(log_std) * z;
      actions[env * ACTIONS + a] = action;
      rollout_actions[row * ACTIONS + a] = action;
      log_prob += gaussian_log_prob(z, log_std);
    }
    rollout_log_prob[row] = log_prob;
  }
}
