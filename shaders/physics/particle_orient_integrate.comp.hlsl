// Substep start for strand segment frames: remember them, damp the angular velocity with the
// strand's damping, and turn each frame by it (no torques act on frames but the constraints).
#include "cressim/layout.h"
#include "cressim/particle.h"
#include "cressim/quat.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<ParticleObject> objects;
StructuredBuffer<uint4> phases;
StructuredBuffer<uint> edge_particles;
RWStructuredBuffer<float4> orientations;
RWStructuredBuffer<float4> prev_orientations;
RWStructuredBuffer<float4> angular_velocities;

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint e = id.x;
  if (e >= pc.edge_count) return;
  const float h = pc.gravity.w;
  const float4 q = orientations[e];
  prev_orientations[e] = q;
  const float3 w = angular_velocities[e].xyz / (1 + h * objects[phases[edge_particles[e]].y].material.z);
  angular_velocities[e].xyz = w;
  orientations[e] = quat_add_rotation(q, w * h);
}
