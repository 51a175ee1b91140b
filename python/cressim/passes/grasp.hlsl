// Grasp, a thread per env. A grasp that closes attaches the movable soft-body and strand
// particles within `radius` of its point (fixed in a rigid body: between a tool's jaws) to that
// body where they are, nearest first, one per attachment slot of the env; a grasp that opens
// frees them. A grasp closed on nothing stays empty until it opens (jaws that are already shut
// do not pick up what they touch later).
// grasps (int4 per env): x command (1 closed, 0 open; written by the host or a task pass),
//   y the rigid body, z state (written here: 0 open, 1 holding, 2 closed on nothing), w held.
// grasp_points (float4 per env): xyz the point in the body frame (m), w the radius (m).
// Slots: the env's control.particle_attachments rows env * slots .. + slots - 1, all of them.
#include "cressim/layout.h"
#include "cressim/particle.h"
#include "cressim/quat.h"
#include "cressim/rigid.h"

struct Params { uint envs; uint slots; uint pad0; uint pad1; };
[[vk::push_constant]] ConstantBuffer<Params> pc;
StructuredBuffer<float4> positions;
StructuredBuffer<uint4> phases;
StructuredBuffer<ParticleEnvRange> env_ranges;
StructuredBuffer<float4> body_positions;
StructuredBuffer<float4> body_rotations;
StructuredBuffer<float4> grasp_points;
RWStructuredBuffer<int4> grasps;
RWStructuredBuffer<ParticleAttachment> attachments;

static const uint MAX_SLOTS = 16;

[numthreads(64, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint env = id.x;
  if (env >= pc.envs) return;
  int4 g = grasps[env];
  const uint first = env * pc.slots, slots = min(pc.slots, MAX_SLOTS);
  if (g.x == 0) {
    if (g.z != 0) {
      for (uint s = 0; s < pc.slots; ++s) attachments[first + s].ids.z = ATTACH_FREE;
      grasps[env] = int4(g.x, g.y, 0, 0);
    }
    return;
  }
  if (g.z != 0) return;  // closed already: holding, or on nothing
  const uint b = uint(g.y);
  const float4 gp = grasp_points[env];
  const float3 centre = body_positions[b].xyz + quat_rotate(body_rotations[b], gp.xyz);
  // the nearest `slots` particles within reach, kept sorted by distance
  uint chosen[MAX_SLOTS];
  float dist[MAX_SLOTS];
  uint count = 0;
  const uint4 range = env_ranges[env].range;
  for (uint i = range.x; i < range.x + range.y; ++i) {
    const float4 x = positions[i];
    const uint4 ph = phases[i];
    if (x.w <= 0 || (ph.w & PARTICLE_ACTIVE) == 0 || ph.x == PARTICLE_FLUID) continue;
    const float d = length(x.xyz - centre);
    if (d > gp.w || (count == slots && d >= dist[count - 1])) continue;
    uint k = count < slots ? count++ : count - 1;
    for (; k > 0 && dist[k - 1] > d; --k) {
      chosen[k] = chosen[k - 1];
      dist[k] = dist[k - 1];
    }
    chosen[k] = i;
    dist[k] = d;
  }
  for (uint s = 0; s < count; ++s) {
    ParticleAttachment a = attachments[first + s];
    a.ids = uint4(chosen[s], b, ATTACH_PENDING, env);
    a.local = float4(0, 0, 0, 0);  // offset taken from the poses at the next step; rigid
    a.hold = uint4(CRESSIM_NONE, 0, 0, 0);
    attachments[first + s] = a;
  }
  grasps[env] = int4(g.x, g.y, count > 0 ? 1 : 2, int(count));
}
