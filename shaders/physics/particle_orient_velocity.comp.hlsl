// Substep end for strand segment frames: angular velocities from the frames' change.
#include "cressim/layout.h"
#include "cressim/particle.h"
#include "cressim/quat.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<float4> orientations;
StructuredBuffer<float4> prev_orientations;
RWStructuredBuffer<float4> angular_velocities;

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint e = id.x;
  if (e >= pc.edge_count) return;
  const float4 dq = quat_mul(orientations[e], quat_conj(prev_orientations[e]));
  angular_velocities[e].xyz = (dq.w >= 0 ? 2.0 : -2.0) * dq.xyz / pc.gravity.w;
}
