// One frame of rigid-body dynamics for every env: one thread per env runs all substeps of its
// env (Gauss-Seidel inside an env, envs in parallel, so envs never interact).
// Per substep: integrate, collide, project joints and contacts, derive velocities, then
// velocity-level friction and restitution (after Mueller et al. 2020). At the end: joint coordinates,
// transforms of the bodies' entities, and the env's health.
#include "cressim/layout.h"
#include "cressim/quat.h"
#include "cressim/rigid.h"

[[vk::push_constant]] ConstantBuffer<RigidConstants> pc;
StructuredBuffer<EnvRigidRange> env_ranges;
StructuredBuffer<BodyModel> bodies;
StructuredBuffer<ColliderModel> colliders;
StructuredBuffer<JointModel> joints;
StructuredBuffer<uint2> filtered_pairs;       // body pairs that do not collide (jointed)
StructuredBuffer<float4> joint_targets;       // control: drive targets
StructuredBuffer<float4> target_positions;    // control: kinematic body targets
StructuredBuffer<float4> target_rotations;
RWStructuredBuffer<float4> positions;
RWStructuredBuffer<float4> rotations;
RWStructuredBuffer<float4> linear_velocities;
RWStructuredBuffer<float4> angular_velocities;
RWStructuredBuffer<float4> prev_positions;    // scratch: pose at the substep start
RWStructuredBuffer<float4> prev_rotations;
RWStructuredBuffer<Contact> contacts;         // scratch: max_contacts per env
RWStructuredBuffer<float4> joint_lambdas;     // scratch
RWStructuredBuffer<float> joint_positions;    // out: hinge angle / slider offset
RWStructuredBuffer<float> joint_velocities;   // out; holds the substep-start coordinate meanwhile
RWStructuredBuffer<float4> transform_positions;
RWStructuredBuffer<float4> transform_rotations;
RWStructuredBuffer<uint> health;
RWStructuredBuffer<uint> reset_mask;

#include "rigid_bodies.hlsli"
#include "rigid_joints.hlsli"
#include "rigid_collide.hlsli"

void integrate(uint b, float h, uint substeps_left) {
  prev_positions[b] = positions[b];
  prev_rotations[b] = rotations[b];
  const BodyModel m = bodies[b];
  if ((m.ids.z & BODY_KINEMATIC) != 0) {
    // cover the rest of the way to the target in equal parts, so contacts see its speed
    const float f = 1.0 / substeps_left;
    positions[b].xyz += f * (target_positions[b].xyz - positions[b].xyz);
    float4 tq = target_rotations[b];
    if (dot(tq, rotations[b]) < 0) tq = -tq;
    rotations[b] = normalize(lerp(rotations[b], tq, f));
    return;
  }
  if (m.inv_inertia.w <= 0) return;
  float3 v = linear_velocities[b].xyz + h * pc.gravity.xyz;
  v /= 1 + h * m.damping.x;
  linear_velocities[b].xyz = v;
  positions[b].xyz += h * v;
  // gyroscopic term in the body frame (skipped for bodies with a locked axis)
  const float4 q = rotations[b];
  float3 w = quat_unrotate(q, angular_velocities[b].xyz);
  if (all(m.inv_inertia.xyz > 0)) {
    const float3 inertia = 1.0 / m.inv_inertia.xyz;
    w += h * m.inv_inertia.xyz * -cross(w, inertia * w);
  }
  w /= 1 + h * m.damping.y;
  angular_velocities[b].xyz = quat_rotate(q, w);
  rotations[b] = quat_add_rotation(q, angular_velocities[b].xyz * h);
}

void update_velocity(uint b, float h) {
  if (!is_dynamic(b) && (bodies[b].ids.z & BODY_KINEMATIC) == 0) return;
  linear_velocities[b].xyz = (positions[b].xyz - prev_positions[b].xyz) / h;
  float4 dq = quat_mul(rotations[b], quat_conj(prev_rotations[b]));
  angular_velocities[b].xyz = (dq.w >= 0 ? 2.0 : -2.0) * dq.xyz / h;
}

bool pair_filtered(EnvRigidRange r, uint a, uint b) {
  if (a == b) return true;
  for (uint i = r.joints.z; i < r.joints.z + r.joints.w; ++i) {
    const uint2 p = filtered_pairs[i];
    if ((p.x == a && p.y == b) || (p.x == b && p.y == a)) return true;
  }
  return false;
}

void generate_contacts(EnvRigidRange r, inout ContactSink sink) {
  const uint first = r.bodies.z, last = r.bodies.z + r.bodies.w;
  for (uint i = first; i < last; ++i) {
    const ColliderModel ci = colliders[i];
    if (ci.ids.w == 0) continue;
    for (uint k = i + 1; k < last; ++k) {
      const ColliderModel ck = colliders[k];
      if ((ci.ids.z & ck.ids.w) == 0 || (ck.ids.z & ci.ids.w) == 0) continue;
      if (!is_dynamic(ci.ids.x) && !is_dynamic(ck.ids.x)) continue;
      if (pair_filtered(r, ci.ids.x, ck.ids.x)) continue;
      collide(sink, ci, ck);
    }
  }
}

void solve_contacts(ContactSink sink) {
  for (uint i = sink.base; i < sink.base + sink.count; ++i) {
    Contact c = contacts[i];
    const uint a = c.bodies.x, b = c.bodies.y;
    const float3 n = c.normal.xyz;
    const float3 pa = to_world(a, c.anchor_a.xyz), pb = to_world(b, c.anchor_b.xyz);
    const float depth = dot(pb - pa, n);
    if (depth <= 0) continue;
    float lambda_n = c.anchor_a.w;
    correct_position(a, b, pa - body_position(a), pb - body_position(b), depth * n, 0, lambda_n, 3.4e38);
    c.anchor_a.w = lambda_n;
    contacts[i] = c;
  }
}

void solve_contact_velocities(ContactSink sink, float h) {
  const float rest_speed = 2.0 * length(pc.gravity.xyz) * h;
  for (uint i = sink.base; i < sink.base + sink.count; ++i) {
    const Contact c = contacts[i];
    const float lambda_n = c.anchor_a.w;
    if (lambda_n <= 0) continue;
    const uint a = c.bodies.x, b = c.bodies.y;
    const float3 n = c.normal.xyz;
    const float3 ra = to_world(a, c.anchor_a.xyz) - body_position(a), rb = to_world(b, c.anchor_b.xyz) - body_position(b);
    const float3 v = point_velocity(a, ra) - point_velocity(b, rb);
    const float vn = dot(n, v);
    const float3 vt = v - vn * n;
    const float speed_t = length(vt);
    // Coulomb friction at the velocity level: stick when the static limit can stop the slide,
    // else slow it by the dynamic limit (position-level static friction biases resting contacts)
    float3 dv = float3(0, 0, 0);
    if (speed_t > 1e-9) {
      const float limit = lambda_n / h;
      dv -= speed_t <= c.material.x * limit ? vt : vt / speed_t * min(c.material.y * limit, speed_t);
    }
    const float vn_before = c.anchor_b.w;
    const float e = abs(vn_before) <= rest_speed ? 0 : c.material.z;
    dv += n * (-vn + max(-e * vn_before, 0));
    change_velocity(a, b, ra, rb, dv);
  }
}

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint env = id.x;
  if (env >= pc.env_count) return;
  const EnvRigidRange r = env_ranges[env];
  const uint b0 = r.bodies.x, b1 = r.bodies.x + r.bodies.y;
  const uint j0 = r.joints.x, j1 = r.joints.x + r.joints.y;
  const float h = pc.gravity.w / pc.substeps;
  ContactSink sink;
  sink.base = env * pc.max_contacts;
  sink.count = 0;
  sink.deepest = 0;

  for (uint s = 0; s < pc.substeps; ++s) {
    for (uint j = j0; j < j1; ++j) {
      joint_velocities[j] = joint_coordinate(joints[j], joint_frames(joints[j]));
      joint_lambdas[j] = float4(0, 0, 0, 0);
    }
    for (uint b = b0; b < b1; ++b) integrate(b, h, pc.substeps - s);
    sink.count = 0;
    sink.deepest = 0;
    generate_contacts(r, sink);
    for (uint it = 0; it < pc.iterations; ++it) {
      for (uint j = j0; j < j1; ++j) solve_joint(j, h, joint_velocities[j]);
      solve_contacts(sink);
    }
    for (uint b = b0; b < b1; ++b) update_velocity(b, h);
    solve_contact_velocities(sink, h);
  }

  for (uint j = j0; j < j1; ++j) {
    const JointModel jm = joints[j];
    const float q = joint_coordinate(jm, joint_frames(jm));
    float dq = q - joint_velocities[j];
    if (jm.ids.z == JOINT_HINGE) dq = wrap_angle(dq);
    joint_positions[j] = q;
    joint_velocities[j] = dq / h;
  }

  uint flags = 0;
  for (uint b = b0; b < b1; ++b) {
    const float4 x = positions[b], q = rotations[b], v = linear_velocities[b], w = angular_velocities[b];
    if (any(isnan(x)) || any(isnan(q)) || any(isnan(v)) || any(isnan(w)) || any(isinf(x)) || any(isinf(v)))
      flags |= HEALTH_NAN;
    else if (length(v.xyz) > pc.max_speed)
      flags |= HEALTH_SPEED;
    const uint row = bodies[b].ids.x;
    transform_positions[row] = float4(x.xyz, 1);
    transform_rotations[row] = q;
  }
  if (sink.deepest > pc.max_penetration) flags |= HEALTH_PENETRATION;
  health[env] = flags;
  if (flags != 0) reset_mask[env] = 1;
}
