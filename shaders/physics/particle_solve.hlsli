// Entry points of a positional constraint family (one that moves particle positions only). The
// family's constraint is in particle_<family>.hlsli:
//   uint evaluate_<family>(ParticleConstraint rec, float3 x[4], out float C, out float3 g[4])
// (value and gradients at its particles' positions x; returns how many particles it has). Its
// pass file includes that, defines `evaluate` as it and includes this file after it.
// cmake/shaders.cmake builds it two ways:
// - by default one dispatch per colour: a thread per constraint, straight on `positions`;
// - with CRESSIM_BLOCK = N (the `.blockN` passes) one workgroup per env of at most N particles:
//   the env's particles go to group memory, every colour is projected in turn (a group barrier
//   between colours) pc.item_offset times over, then written back. That is one dispatch where the
//   first needs colours x passes, and dispatches, not arithmetic, bound small soft bodies in
//   many envs. It reads its records from `block_records`, 16 bytes each (particle_block_pack):
//   with the whole record and its cut flag (36 bytes), SoftBodyPush's 512 envs read 65 MB a
//   pass with the multipliers, more than the H100's 50 MB L2: every colour step waited on memory.
// Both skip cut records (control.particle_<family>_cut). A family whose evaluate() reads
// params.zw defines CRESSIM_RECORD_ZW first: the block build then loads them from the record.

#ifndef CRESSIM_BLOCK

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint c = constraint_index(id.x);
  if (c == CRESSIM_NONE) return;
  const ParticleConstraint rec = constraints[c];
  const uint ids[4] = {rec.particles.x, rec.particles.y, rec.particles.z, rec.particles.w};
  float3 x[4];
  float w[4];
  for (uint k = 0; k < 4; ++k) {
    const float4 p = ids[k] == CRESSIM_NONE ? float4(0, 0, 0, 0) : positions[ids[k]];
    x[k] = p.xyz;
    w[k] = p.w;
  }
  float C;
  float3 g[4];
  const uint n = evaluate(rec, x, C, g);
  const float dl = xpbd_delta(rec, n, C, g, w, lambdas[c]);
  lambdas[c] += dl;
  // whole float4 stores from the registers: a colour's records share no particle, and the
  // read-modify-write of .xyz alone costs a load and three stores a particle
  for (uint k = 0; k < n; ++k) positions[ids[k]] = float4(x[k] + w[k] * dl * g[k], w[k]);
}

#else

#include "particle_block.hlsli"
StructuredBuffer<ParticleEnvRange> env_ranges;
StructuredBuffer<uint2> env_colours;  // (first, count) of this family's records per env and colour
StructuredBuffer<uint4> block_records;
groupshared float4 block_x[CRESSIM_BLOCK];
// 256 threads: a colour of SoftBodyPush's edges (up to 171 records) is one step for every thread,
// and its solve took 3.5 instead of 4.2 ms a frame at 512 envs (H100; benchmarks/README.md, with
// what else was tried: records and multipliers in group memory, the next colour's prefetched)
static const uint BLOCK_THREADS = 256;
#ifdef CRESSIM_RECORD_ZW
#define RECORD_ZW(c) constraints[c].params.zw
#else
#define RECORD_ZW BLOCK_NO_ZW
#endif

[numthreads(BLOCK_THREADS, 1, 1)]
void main(uint3 group : SV_GroupID, uint3 thread : SV_GroupThreadID) {
  const uint env = group.x, lane = thread.x;
  const uint first = env_ranges[env].range.x, count = env_ranges[env].range.y;
  for (uint i = lane; i < count; i += BLOCK_THREADS) block_x[i] = positions[first + i];
  GroupMemoryBarrierWithGroupSync();
  BLOCK_SOLVE_COLOURS(evaluate, block_records, lambdas, env_colours, RECORD_ZW, env, pc.item_count, pc.item_offset,
                      lane, BLOCK_THREADS)
  for (uint i = lane; i < count; i += BLOCK_THREADS) positions[first + i] = block_x[i];
}

#endif
