// Task entries that run a thread group an env (VectorEnv.group_entries): the group's threads
// stride over the env's particles and sum what they see (env_group_sum). One thread an env
// walking all of them was most of SoftBodyPush's and FluidPour's task time (343 and 960
// particles: 0.28 and 0.37 ms a step at 512 and 128 envs on an H100).
static const uint ENV_GROUP = 64;  // vector_env.py's ENV_GROUP
groupshared float4 env_group_sums[ENV_GROUP];

// the sum of every lane's v, returned to every lane (all of the group must call it)
float4 env_group_sum(float4 v, uint lane) {
  env_group_sums[lane] = v;
  GroupMemoryBarrierWithGroupSync();
  for (uint s = ENV_GROUP / 2; s > 0; s >>= 1) {
    if (lane < s) env_group_sums[lane] += env_group_sums[lane + s];
    GroupMemoryBarrierWithGroupSync();
  }
  return env_group_sums[0];
}
