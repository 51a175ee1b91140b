// Forward kinematics of URDF links on the GPU, a thread per (env, link): the link's pose is the
// arm's base pose times, along its path from the root, each joint's origin and then its motion
// (a rotation about its axis for revolute joints, a shift along it for prismatic ones), the
// joint's value being gain x joint_values[env, source] + offset (mimic joints follow their
// source). The pose becomes the kinematic body's target (the engine moves it there over the
// substeps), so an arm posed here costs one dispatch, not a host round trip.
// steps: 4 float4 each: (origin xyz, type: 0 fixed, 1 revolute, 2 prismatic), origin quaternion
// (xyzw), (axis xyz, gain), (source column, offset, -, -).
#include "cressim/quat.h"

struct Params {
  uint envs;
  uint links;    // per env
  uint columns;  // joint_values' row length
  uint pad;
  float4 base_position;  // xyz
  float4 base_rotation;  // xyzw
};
[[vk::push_constant]] ConstantBuffer<Params> pc;

StructuredBuffer<float4> steps;
StructuredBuffer<uint2> link_steps;      // per link: first step, count
StructuredBuffer<uint> link_rows;        // (envs, links): the body row of each link
StructuredBuffer<float> joint_values;    // (envs, columns)
RWStructuredBuffer<float4> target_positions;  // control.body_target_positions
RWStructuredBuffer<float4> target_rotations;  // control.body_target_rotations

[numthreads(64, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  if (id.x >= pc.envs * pc.links) return;
  const uint env = id.x / pc.links, link = id.x % pc.links;
  float3 p = pc.base_position.xyz;
  float4 q = pc.base_rotation;
  const uint2 range = link_steps[link];
  for (uint s = range.x; s < range.x + range.y; ++s) {
    const float4 origin = steps[4 * s], rotation = steps[4 * s + 1], axis = steps[4 * s + 2],
                 source = steps[4 * s + 3];
    p += quat_rotate(q, origin.xyz);
    q = quat_mul(q, rotation);
    if (origin.w == 0) continue;
    const float value = axis.w * joint_values[env * pc.columns + uint(source.x)] + source.y;
    if (origin.w == 1) q = quat_mul(q, quat_axis_angle(axis.xyz, value));
    else p += quat_rotate(q, axis.xyz * value);
  }
  const uint row = link_rows[id.x];
  target_positions[row] = float4(p, target_positions[row].w);  // w is the engine's
  target_rotations[row] = normalize(q);
}
