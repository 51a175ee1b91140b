// The exploration noise of the engine's policy passes (engine_policy.hlsl, engine_cnn.hlsl): one
// N(0, 1) draw per (seed, env in the whole batch, the env's step, action), so a shard draws the
// numbers of its envs in the whole batch and the MLP and CNN passes explore alike.

uint pcg_hash(uint v) {
  const uint state = v * 747796405u + 2891336453u;
  const uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
  return (word >> 22u) ^ word;
}

// N(0, 1) by Box-Muller from two hashed uniforms
float gaussian(uint seed, uint env, uint step, uint action) {
  const uint key = pcg_hash(seed ^ pcg_hash(env * 7919u + action)) ^ pcg_hash(step * 2654435761u + 97u);
  const uint h1 = pcg_hash(key), h2 = pcg_hash(key ^ 0x9e3779b9u);
  const float u1 = (float(h1 >> 8) + 1.0) * (1.0 / 16777216.0);  // (0, 1]: log stays finite
  const float u2 = float(h2 >> 8) * (1.0 / 16777216.0);
  return sqrt(-2.0 * log(u1)) * cos(6.28318530718 * u2);
}

// log N(mean + std z; mean, std) of one action
float gaussian_log_prob(float z, float log_std) {
  return -0.5 * z * z - log_std - 0.91893853320467274;
}
