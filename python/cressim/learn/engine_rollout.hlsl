// The end of an env step in an engine rollout (engine_rollout.py), one thread per env: the
// task's reward and flags stored at the step's row, the episode statistics summed, the env's
// step count advanced (the next policy pass writes the next row).

struct Params {
  uint envs;
  uint rollout;  // rows of the rollout buffers
};
[[vk::push_constant]] ConstantBuffer<Params> pc;

StructuredBuffer<float> rewards;          // the task's, this step
StructuredBuffer<uint> terminated;
StructuredBuffer<uint> truncated;
StructuredBuffer<float> finished_length;  // the ended episode's length, else 0
RWStructuredBuffer<float> rollout_rewards;   // (rollout, envs)
RWStructuredBuffer<uint> rollout_dones;      // (rollout, envs) terminated or truncated
RWStructuredBuffer<uint> rollout_time_outs;  // (rollout, envs) truncated
RWStructuredBuffer<uint> rollout_step;       // (envs)
// (envs, 5): running return, then the sums since the learner last read them: episodes ended,
// their lengths, their returns, those that terminated
RWStructuredBuffer<float> episode_stats;

[numthreads(64, 1, 1)]
void store(uint3 id : SV_DispatchThreadID) {
  const uint env = id.x;
  if (env >= pc.envs) return;
  const uint step = rollout_step[env], row = (step % pc.rollout) * pc.envs + env;
  const bool term = terminated[env] != 0, trunc = truncated[env] != 0, done = term || trunc;
  rollout_rewards[row] = rewards[env];
  rollout_dones[row] = done ? 1 : 0;
  rollout_time_outs[row] = trunc ? 1 : 0;
  rollout_step[env] = step + 1;

  const uint s = 5 * env;
  const float running = episode_stats[s] + rewards[env];
  episode_stats[s] = done ? 0.0 : running;
  if (done) {
    episode_stats[s + 1] += 1.0;
    episode_stats[s + 2] += finished_length[env];
    episode_stats[s + 3] += running;
    episode_stats[s + 4] += term ? 1.0 : 0.0;
  }
}
