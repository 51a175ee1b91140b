// One frame of rigid-body dynamics for every env: one thread per env runs all substeps of its
// env (Gauss-Seidel inside an env, envs in parallel, so envs never interact).
// Per substep: integrate, collide, project joints and contacts, derive velocities, then
// velocity-level friction and restitution (after Mueller et al. 2020; contacts Jacobi-style). At the end: joint coordinates,
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
RWStructuredBuffer<float4> delta_positions;   // scratch: summed contact corrections, w: contacts
RWStructuredBuffer<float4> delta_rotations;
RWStructuredBuffer<float4> joint_lambdas;     // scratch
RWStructuredBuffer<float> joint_positions;    // out: hinge angle / slider offset
RWStructuredBuffer<float> joint_velocities;   // out; holds the substep-start coordinate meanwhile
RWStructuredBuffer<float4> transform_positions;
RWStructuredBuffer<float4> transform_rotations;
RWStructuredBuffer<uint> health;
RWStructuredBuffer<uint> reset_mask;
RWStructuredBuffer<uint> health_events;       // [0]: envs flagged so far (host-visible, read each frame)

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

// Contacts are solved Jacobi-style: every contact of an env computes its correction from the
// same poses, the corrections are summed per body and applied together. Sequential corner
// contacts rock a box (and rocking about two axes turns it about the third); a simultaneous
// solve is symmetric. Each contact's share is 2 / (contacts on the busier of its two bodies),
// at most 1, the same for both bodies so momentum is kept; the factor 2 over-relaxes the
// averaged solve (contacts on one face mostly share the work of one translation).

void clear_deltas(uint b0, uint b1) {
  for (uint b = b0; b < b1; ++b) {
    delta_positions[b] = float4(0, 0, 0, 0);
    delta_rotations[b] = float4(0, 0, 0, 0);
  }
}

void count_contact(uint b) {
  if (b != CRESSIM_NONE) delta_positions[b].w += 1;
}

float contact_share(uint a, uint b) {
  float n = 1;
  if (a != CRESSIM_NONE) n = max(n, delta_positions[a].w);
  if (b != CRESSIM_NONE) n = max(n, delta_positions[b].w);
  return min(1.0, 2.0 / n);
}

// an impulse-like correction p at arm r: sign +1 for a, -1 for b
void accumulate(uint b, float3 p, float3 r, float sign) {
  if (!is_dynamic(b)) return;
  delta_positions[b].xyz += sign * p * bodies[b].inv_inertia.w;
  delta_rotations[b].xyz += sign * inv_inertia_times(b, cross(r, p));
}

// positional correction `correction` of a against b, accumulated at the contact's share
float accumulate_position(uint a, uint b, float3 ra, float3 rb, float3 correction, float share) {
  const float c = length(correction);
  if (c < 1e-9) return 0;
  const float3 n = correction / c;
  const float w = positional_weight(a, ra, n) + positional_weight(b, rb, n);
  if (w <= 0) return 0;
  const float dl = share * c / w;
  accumulate(a, dl * n, ra, 1);
  accumulate(b, dl * n, rb, -1);
  return dl;
}

void apply_position_deltas(uint b0, uint b1) {
  for (uint b = b0; b < b1; ++b) {
    if (!is_dynamic(b)) continue;
    positions[b].xyz += delta_positions[b].xyz;
    rotations[b] = quat_add_rotation(rotations[b], delta_rotations[b].xyz);
    delta_positions[b].xyz = float3(0, 0, 0);
    delta_rotations[b] = float4(0, 0, 0, 0);
  }
}

void apply_velocity_deltas(uint b0, uint b1) {
  for (uint b = b0; b < b1; ++b) {
    if (!is_dynamic(b)) continue;
    linear_velocities[b].xyz += delta_positions[b].xyz;
    angular_velocities[b].xyz += delta_rotations[b].xyz;
    delta_positions[b].xyz = float3(0, 0, 0);
    delta_rotations[b] = float4(0, 0, 0, 0);
  }
}

void solve_contacts(ContactSink sink, uint b0, uint b1) {
  for (uint i = sink.base; i < sink.base + sink.count; ++i) {
    Contact c = contacts[i];
    const uint a = c.bodies.x, b = c.bodies.y;
    const float3 n = c.normal.xyz;
    const float3 pa = to_world(a, c.anchor_a.xyz), pb = to_world(b, c.anchor_b.xyz);
    const float3 ra = pa - body_position(a), rb = pb - body_position(b);
    const float depth = dot(pb - pa, n);
    if (depth <= 0) continue;
    const float share = contact_share(a, b);
    const float lambda_n = c.anchor_a.w + accumulate_position(a, b, ra, rb, depth * n, share);
    c.anchor_a.w = lambda_n;
    // static friction: undo the tangential slip of the contact points over this substep while
    // the static cone allows it
    float3 pa_prev = pa, pb_prev = pb;
    if (a != CRESSIM_NONE) pa_prev = prev_positions[a].xyz + quat_rotate(prev_rotations[a], c.anchor_a.xyz);
    if (b != CRESSIM_NONE) pb_prev = prev_positions[b].xyz + quat_rotate(prev_rotations[b], c.anchor_b.xyz);
    const float3 slip = (pa - pa_prev) - (pb - pb_prev);
    const float3 tangential = slip - dot(slip, n) * n;
    const float t = length(tangential);
    if (t > 1e-9) {
      const float3 dir = tangential / t;
      const float w = positional_weight(a, ra, dir) + positional_weight(b, rb, dir);
      if (w > 0 && share * t / w <= c.material.x * lambda_n) accumulate_position(a, b, ra, rb, -tangential, share);
    }
    contacts[i] = c;
  }
  apply_position_deltas(b0, b1);
}

void solve_contact_velocities(ContactSink sink, float h, uint b0, uint b1) {
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
    const float share = contact_share(a, b);
    // normal: no approach (or the restitution's rebound), as this contact's share of an impulse
    const float vn_before = c.anchor_b.w;
    const float e = abs(vn_before) <= rest_speed ? 0 : c.material.z;
    const float dvn = -vn + max(-e * vn_before, 0);
    const float wn = positional_weight(a, ra, n) + positional_weight(b, rb, n);
    float3 p = wn > 0 ? n * (share * dvn / wn) : float3(0, 0, 0);
    // dynamic friction: its share of stopping the slide, capped by Coulomb on the contact's own
    // normal impulse (lambda_n is already its share)
    if (speed_t > 1e-9) {
      const float3 dir = vt / speed_t;
      const float wt = positional_weight(a, ra, dir) + positional_weight(b, rb, dir);
      if (wt > 0) p -= dir * min(share * speed_t / wt, c.material.y * lambda_n / h);
    }
    accumulate(a, p, ra, 1);
    accumulate(b, p, rb, -1);
  }
  apply_velocity_deltas(b0, b1);
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
    clear_deltas(b0, b1);
    for (uint k = sink.base; k < sink.base + sink.count; ++k) {
      count_contact(contacts[k].bodies.x);
      count_contact(contacts[k].bodies.y);
    }
    for (uint it = 0; it < pc.iterations; ++it) {
      for (uint j = j0; j < j1; ++j) solve_joint(j, h, joint_velocities[j]);
      if (sink.count > 0) solve_contacts(sink, b0, b1);
    }
    for (uint b = b0; b < b1; ++b) update_velocity(b, h);
    if (sink.count > 0) solve_contact_velocities(sink, h, b0, b1);
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
  if (flags != 0) {
    reset_mask[env] = 1;
    InterlockedAdd(health_events[0], 1u);
  }
}
