// Puts the bodies of every env flagged in env.reset_mask back to their authored poses with the
// velocities in control.body_reset_velocities (linear) and body_reset_angular_velocities, then
// poses each joint's child from its parent (hinges and sliders moved by the coordinate in
// control.joint_reset: x position, y velocity), joints in parent-before-child order. One thread per env.
#include "cressim/layout.h"
#include "cressim/quat.h"
#include "cressim/rigid.h"

struct Params { uint env_count; };
[[vk::push_constant]] ConstantBuffer<Params> pc;
StructuredBuffer<EnvRigidRange> env_ranges;
StructuredBuffer<JointModel> joints;
StructuredBuffer<uint> reset_mask;
StructuredBuffer<float4> initial_positions;
StructuredBuffer<float4> initial_rotations;
StructuredBuffer<float4> joint_reset;
StructuredBuffer<float4> reset_linear_velocities;
StructuredBuffer<float4> reset_angular_velocities;
RWStructuredBuffer<float4> positions;
RWStructuredBuffer<float4> rotations;
RWStructuredBuffer<float4> linear_velocities;
RWStructuredBuffer<float4> angular_velocities;
RWStructuredBuffer<float4> target_positions;
RWStructuredBuffer<float4> target_rotations;
RWStructuredBuffer<uint> health;
RWStructuredBuffer<float> joint_positions;
RWStructuredBuffer<float> joint_velocities;

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint env = id.x;
  if (env >= pc.env_count || reset_mask[env] == 0) return;
  const EnvRigidRange r = env_ranges[env];
  for (uint b = r.bodies.x; b < r.bodies.x + r.bodies.y; ++b) {
    positions[b] = initial_positions[b];
    rotations[b] = initial_rotations[b];
    target_positions[b] = initial_positions[b];
    target_rotations[b] = initial_rotations[b];
    linear_velocities[b] = float4(reset_linear_velocities[b].xyz, 0);
    angular_velocities[b] = float4(reset_angular_velocities[b].xyz, 0);
  }
  for (uint j = r.joints.x; j < r.joints.x + r.joints.y; ++j) {
    const JointModel jm = joints[j];
    const uint a = jm.ids.x, b = jm.ids.y, kind = jm.ids.z;
    if (b == CRESSIM_NONE) continue;
    const bool moves = kind == JOINT_HINGE || kind == JOINT_SLIDER;
    const float q = moves ? joint_reset[j].x : 0, qd = moves ? joint_reset[j].y : 0;
    joint_positions[j] = q;  // observable before the next step
    joint_velocities[j] = qd;
    const float3 xa = a == CRESSIM_NONE ? float3(0, 0, 0) : positions[a].xyz;
    const float4 qa = a == CRESSIM_NONE ? float4(0, 0, 0, 1) : rotations[a];
    // joint frame on a, moved by the coordinate, is the joint frame on b
    float3 frame_p = xa + quat_rotate(qa, jm.frame_a_position.xyz);
    float4 frame_q = quat_mul(qa, jm.frame_a_rotation);
    const float3 axis = quat_rotate(frame_q, float3(1, 0, 0));
    if (kind == JOINT_SLIDER) frame_p += q * axis;
    if (kind == JOINT_HINGE) frame_q = quat_mul(quat_axis_angle(axis, q), frame_q);
    const float4 qb = quat_mul(frame_q, quat_conj(jm.frame_b_rotation));
    const float3 xb = frame_p - quat_rotate(qb, jm.frame_b_position.xyz);
    positions[b].xyz = xb;
    rotations[b] = qb;
    // velocity: the parent's motion carried to b, plus the joint's own rate
    const float3 va = a == CRESSIM_NONE ? float3(0, 0, 0) : linear_velocities[a].xyz;
    const float3 wa = a == CRESSIM_NONE ? float3(0, 0, 0) : angular_velocities[a].xyz;
    float3 vb = va + cross(wa, xb - xa), wb = wa;
    if (kind == JOINT_SLIDER) vb += qd * axis;
    if (kind == JOINT_HINGE) { wb += qd * axis; vb += cross(qd * axis, xb - frame_p); }
    linear_velocities[b].xyz = vb;
    angular_velocities[b].xyz = wb;
    target_positions[b] = positions[b];
    target_rotations[b] = qb;
  }
  health[env] = 0;
}
