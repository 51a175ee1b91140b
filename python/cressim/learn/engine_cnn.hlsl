// A CNN policy's step inside the engine's frame (engine_cnn.py): TASKS.md's image actor
// (convolutions, then linear layers, ReLU between) as one `gemm` pass a layer and a `head` pass
// (the last linear layer, the exploration noise, the action and the rollout's row).
// engine_cnn.py prepends each pass's shapes (the defines and constants used below).
//
// `gemm`: a layer as a matrix product (an implicit GEMM): rows m = (env, output pixel), columns
// n = output channels (or units), sums over k = (input channel, kernel row, kernel column) as
// torch's weights (out, in, kh, kw) lie. A group computes a TILE_M x TILE_N tile of outputs, each
// thread 4 x 4 of them in registers; K_CHUNK columns of inputs and rows of weights at a time are
// staged in groupshared memory (the weights read along k: coalesced), so each value read from
// memory serves TILE_N (inputs) or TILE_M (weights) products. A layer with few tiles (a linear
// layer over few envs) splits k over SPLIT groups; the next pass sums the SPLIT partial sums,
// adds the bias and applies the activation as it reads them.

#include "policy_noise.hlsli"

struct Params {
  uint envs;
  uint rollout;     // head: rows of the rollout buffers; an env's step t goes to row t % rollout
  uint seed;
  uint env_offset;  // head: env 0's index in the whole batch (a shard draws that batch's noise)
  uint explore;     // head: 0: the mean action (evaluation), 1: mean + std * N(0, 1)
};
[[vk::push_constant]] ConstantBuffer<Params> pc;

// torch's parameters as they lie in memory: per layer weight then bias, then log_std (ACTIONS)
StructuredBuffer<float> weights;
#if OBS_UINT8
StructuredBuffer<uint> observations;      // the task's (envs, ...) uint8 image as words
RWStructuredBuffer<uint> rollout_obs;     // (rollout, envs, OBS_WORDS)
#else
StructuredBuffer<float> observations;     // the task's (envs, ...) float image
RWStructuredBuffer<float> rollout_obs;
#endif
StructuredBuffer<float> layer_in;         // the previous layer's outputs (SPLIT_IN, envs, C, H, W)
RWStructuredBuffer<float> layer_out;      // this layer's (SPLIT, envs, C, H, W)
RWStructuredBuffer<float> actions;        // head: the task's (envs, ACTIONS)
RWStructuredBuffer<float> rollout_actions;  // (rollout, envs, ACTIONS)
RWStructuredBuffer<float> rollout_log_prob; // (rollout, envs)
StructuredBuffer<uint> rollout_step;      // (envs) steps taken so far, advanced by the store pass

float activate(float x, uint kind) {
  if (kind == 0) return 1.0 - 2.0 / (exp(2.0 * x) + 1.0);  // tanh, not the intrinsic (engine_policy.hlsl says why)
  if (kind == 1) return x > 0.0 ? x : exp(x) - 1.0;        // elu, alpha 1
  if (kind == 2) return max(x, 0.0);                       // relu
  return x;                                                // none
}

// feature f of the previous layer's outputs (C, H, W) for `env`: stored final, or SPLIT_IN partial
// sums to add up with the bias of its channel (IN_PLANE = H W features a channel) and the activation
float previous(uint env, uint f) {
  if (SPLIT_IN == 1) return layer_in[env * IN_SIZE + f];
  float x = weights[IN_BIAS + f / IN_PLANE];
  for (uint s = 0; s < SPLIT_IN; ++s) x += layer_in[(s * pc.envs + env) * IN_SIZE + f];
  return activate(x, IN_ACT);
}

// ----------------------------------------------------------------------------------------------
// gemm: defines FIRST (1: reads the observations), OBS_CHANNELS_LAST, IN_C, IN_H, IN_W, KSIZE,
// STRIDE, OUT_C, OUT_H, OUT_W, W_OFF, B_OFF, ACT, SPLIT, K_PER_SPLIT, TM, TN, K_CHUNK,
// A_K_FASTEST (1: a linear layer, inputs contiguous along k); IN_SIZE, SPLIT_IN, IN_BIAS, IN_ACT, IN_PLANE
#ifdef TM
static const uint THREADS = TM * TN, RM = 4, RN = 4, TILE_M = TM * RM, TILE_N = TN * RN;
static const uint KK = KSIZE * KSIZE, K = IN_C * KK, IN_HW = IN_H * IN_W, OUT_HW = OUT_H * OUT_W;
static const uint OUT_SIZE = OUT_C * OUT_HW;
// a thread's 4 rows and 4 columns lie side by side: one float4 read each a k (a warp's weights
// read is one broadcast); rows padded by a float4 so that writes along k spread over banks
static const uint A_ROW = TILE_M / 4 + 1, B_ROW = TILE_N / 4 + 1;
groupshared float4 a_tile[K_CHUNK * A_ROW];
groupshared float4 b_tile[K_CHUNK * B_ROW];
static const uint A_LOADS = (TILE_M * K_CHUNK + THREADS - 1) / THREADS;  // a thread's share of a chunk
static const uint B_LOADS = (TILE_N * K_CHUNK + THREADS - 1) / THREADS;

// the input at channel c, row y, column x of `env`'s image
float input_at(uint env, uint c, uint y, uint x) {
#if FIRST
  const uint i = env * IN_SIZE + (OBS_CHANNELS_LAST ? (y * IN_W + x) * IN_C + c : (c * IN_H + y) * IN_W + x);
#if OBS_UINT8
  return float((observations[i >> 2] >> ((i & 3) * 8)) & 0xff) / 255.0;  // as the torch module scales uint8
#else
  return observations[i];
#endif
#else
  return previous(env, (c * IN_H + y) * IN_W + x);
#endif
}

// element i of a chunk's A (inputs) tile: (k in the chunk, row in the tile); neighbouring threads
// take neighbouring pixels of a convolution, neighbouring k of a linear layer (contiguous inputs)
uint2 a_place(uint i) {
#if A_K_FASTEST
  return uint2(i % K_CHUNK, i / K_CHUNK);
#else
  return uint2(i / TILE_M, i % TILE_M);
#endif
}
float a_value(uint i, uint m0, uint k0, uint k_end, uint rows) {
  const uint2 at = a_place(i);
  const uint m = m0 + at.y, k = k0 + at.x;
  if (i >= TILE_M * K_CHUNK || m >= rows || k >= k_end) return 0.0;
  const uint p = m % OUT_HW, c = k / KK, tap = k % KK;
  return input_at(m / OUT_HW, c, (p / OUT_W) * STRIDE + tap / KSIZE, (p % OUT_W) * STRIDE + tap % KSIZE);
}
// element i of a chunk's B (weights) tile: along k, torch's rows (coalesced)
float b_value(uint i, uint n0, uint k0, uint k_end) {
  const uint n = n0 + i / K_CHUNK, k = k0 + i % K_CHUNK;
  return i < TILE_N * K_CHUNK && n < OUT_C && k < k_end ? weights[W_OFF + n * K + k] : 0.0;
}

[numthreads(THREADS, 1, 1)]
void gemm(uint3 group_id : SV_GroupID, uint3 thread_id : SV_GroupThreadID) {
  const uint tid = thread_id.x, tm = tid % TM, tn = tid / TM;
  const uint m0 = group_id.x * TILE_M, n0 = group_id.y * TILE_N, rows = pc.envs * OUT_HW;
  const uint k_begin = group_id.z * K_PER_SPLIT, k_end = min(K, k_begin + K_PER_SPLIT);
  float4 acc[RM];  // acc[i][j]: row m0 + 4 tm + i, column n0 + 4 tn + j
  [unroll] for (uint r = 0; r < RM; ++r) acc[r] = 0.0;

  // the next chunk is read from memory into registers while this one is multiplied
  float a_next[A_LOADS], b_next[B_LOADS];
  [unroll] for (uint r = 0; r < A_LOADS; ++r) a_next[r] = a_value(tid + r * THREADS, m0, k_begin, k_end, rows);
  [unroll] for (uint r = 0; r < B_LOADS; ++r) b_next[r] = b_value(tid + r * THREADS, n0, k_begin, k_end);
  for (uint k0 = k_begin; k0 < k_end; k0 += K_CHUNK) {
    [unroll] for (uint r = 0; r < A_LOADS; ++r) {
      const uint i = tid + r * THREADS;
      const uint2 at = a_place(i);
      if (i < TILE_M * K_CHUNK) a_tile[at.x * A_ROW + at.y / 4][at.y % 4] = a_next[r];
    }
    [unroll] for (uint r = 0; r < B_LOADS; ++r) {
      const uint i = tid + r * THREADS, nn = i / K_CHUNK;
      if (i < TILE_N * K_CHUNK) b_tile[(i % K_CHUNK) * B_ROW + nn / 4][nn % 4] = b_next[r];
    }
    GroupMemoryBarrierWithGroupSync();
    const uint k1 = k0 + K_CHUNK;
    if (k1 < k_end) {
      [unroll] for (uint r = 0; r < A_LOADS; ++r) a_next[r] = a_value(tid + r * THREADS, m0, k1, k_end, rows);
      [unroll] for (uint r = 0; r < B_LOADS; ++r) b_next[r] = b_value(tid + r * THREADS, n0, k1, k_end);
    }
    [unroll] for (uint kk = 0; kk < K_CHUNK; ++kk) {
      const float4 a = a_tile[kk * A_ROW + tm], b = b_tile[kk * B_ROW + tn];
      [unroll] for (uint i = 0; i < RM; ++i) acc[i] += a[i] * b;
    }
    GroupMemoryBarrierWithGroupSync();
  }

  [unroll] for (uint i = 0; i < RM; ++i) {
    const uint m = m0 + RM * tm + i;
    if (m >= rows) continue;
    const uint env = m / OUT_HW, p = m % OUT_HW;
    [unroll] for (uint j = 0; j < RN; ++j) {
      const uint n = n0 + RN * tn + j;
      if (n >= OUT_C) continue;
      if (SPLIT == 1) layer_out[env * OUT_SIZE + n * OUT_HW + p] = activate(acc[i][j] + weights[B_OFF + n], ACT);
      else layer_out[(group_id.z * pc.envs + env) * OUT_SIZE + n * OUT_HW + p] = acc[i][j];
    }
  }
}
#endif

// ----------------------------------------------------------------------------------------------
// head: a group an env. Defines HEAD_GROUP, OBS_WORDS, ACTIONS, W_OFF, B_OFF, LOG_STD; IN_SIZE
// (the last layer's inputs), SPLIT_IN, IN_BIAS, IN_ACT, IN_PLANE
#ifdef HEAD_GROUP
groupshared float hidden[IN_SIZE];
groupshared float sums[HEAD_GROUP * ACTIONS];

[numthreads(HEAD_GROUP, 1, 1)]
void head(uint3 group_id : SV_GroupID, uint3 thread_id : SV_GroupThreadID) {
  const uint env = group_id.x, tid = thread_id.x;
  const uint step = rollout_step[env], row = (step % pc.rollout) * pc.envs + env;
  // the observation the actor saw, stored as the rollout's (words: uint8 images copy 4 bytes at once)
  for (uint i = tid; i < OBS_WORDS; i += HEAD_GROUP)
    rollout_obs[row * OBS_WORDS + i] = observations[env * OBS_WORDS + i];
  for (uint f = tid; f < IN_SIZE; f += HEAD_GROUP) hidden[f] = previous(env, f);
  GroupMemoryBarrierWithGroupSync();
  for (uint a = 0; a < ACTIONS; ++a) {
    float acc = 0.0;
    for (uint f = tid; f < IN_SIZE; f += HEAD_GROUP) acc += weights[W_OFF + a * IN_SIZE + f] * hidden[f];
    sums[a * HEAD_GROUP + tid] = acc;
  }
  GroupMemoryBarrierWithGroupSync();
  for (uint width = HEAD_GROUP / 2; width > 0; width /= 2) {
    if (tid < width)
      for (uint a = 0; a < ACTIONS; ++a) sums[a * HEAD_GROUP + tid] += sums[a * HEAD_GROUP + tid + width];
    GroupMemoryBarrierWithGroupSync();
  }
  if (tid != 0) return;
  float log_prob = 0.0;
  for (uint a = 0; a < ACTIONS; ++a) {
    const float log_std = weights[LOG_STD + a];
    const float z = pc.explore != 0 ? gaussian(pc.seed, env + pc.env_offset, step, a) : 0.0;
    const float action = sums[a * HEAD_GROUP] + weights[B_OFF + a] + exp(log_std) * z;
    actions[env * ACTIONS + a] = action;
    rollout_actions[row * ACTIONS + a] = action;
    log_prob += gaussian_log_prob(z, log_std);
  }
  rollout_log_prob[row] = log_prob;
}
#endif
