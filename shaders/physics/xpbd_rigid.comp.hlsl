// One frame of rigid-body dynamics for every env: one thread per env runs all substeps of its
// env (Gauss-Seidel inside an env, envs in parallel, so envs never interact).
// Per substep: integrate, collide, project joints and contacts, derive velocities, then
// velocity-level restitution (after Mueller et al. 2020). At the end: joint coordinates and
// reaction forces, contact forces, transforms of the bodies' entities, and the env's health.
#include "cressim/layout.h"
#include "cressim/quat.h"
#include "cressim/rigid.h"

[[vk::push_constant]] ConstantBuffer<RigidConstants> pc;
StructuredBuffer<EnvRigidRange> env_ranges;
RWStructuredBuffer<BodyModel> bodies;       // kinematic flag and inverse masses set at the frame's start
StructuredBuffer<float4> dynamic_inertia;     // per body: inverse inertia and mass as authored (0: none)
StructuredBuffer<uint> body_kinematic;        // control: 1 kinematic, 0 dynamic
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
RWStructuredBuffer<float4> contact_forces;    // out: N on each body, world, frame average
RWStructuredBuffer<float4> contact_torques;   // out: N m about the body origin
RWStructuredBuffer<float4> reaction_forces;   // out: N the joint exerts on body b, world
RWStructuredBuffer<float4> reaction_torques;  // out: N m on body b about its joint frame origin
RWStructuredBuffer<float> joint_positions;    // out: hinge angle / slider offset
RWStructuredBuffer<float> joint_velocities;   // out; holds the substep-start coordinate meanwhile
RWStructuredBuffer<float4> transform_positions;
RWStructuredBuffer<float4> transform_rotations;
RWStructuredBuffer<uint> health;
RWStructuredBuffer<uint> reset_mask;
RWStructuredBuffer<uint> health_events;       // [0]: envs flagged so far (host-visible, read each frame)

// below this normal speed a contact does not bounce; above this tangential speed it slides
float rest_speed() { return 2.0 * length(pc.gravity.xyz) * pc.gravity.w / pc.substeps; }

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
  angular_velocities[b].xyz = quat_rotation_between(prev_rotations[b], rotations[b]) / h;
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
  sink.count = 0;
  sink.deepest = 0;
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

// Contacts: non-penetration per contact, Jacobi-style: every contact computes its correction
// from the same poses, the corrections are summed per body and applied together. Sequential
// corner contacts rock a box (and rocking about two axes turns it about the third); a
// simultaneous solve is symmetric. Each contact's share is 2 / (contacts on the busier of its
// two bodies), at most 1, the same for both bodies so momentum is kept; the factor 2
// over-relaxes the averaged solve (contacts on one face mostly share the work of one translation).
// Friction: one constraint per patch (a run of contacts between the same two bodies), at its
// centroid, solved exactly in sequence after the normals: Coulomb |lambda_t| <= sum mu lambda_n,
// plus a twist about the normal limited by the same sum times each contact's distance from the
// centroid. Per-contact friction under the Jacobi average removed only part of a box's slip
// (boxes crept down slopes below the friction angle and slid at the wrong rate above it); solved
// per contact in sequence it is redundant (four corners, one body) and its unconverged internal
// squeeze turned and slid stacked boxes.

static const uint FRICTION_SWEEPS = 4;

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

struct ContactPoints {
  float3 pa, pb;  // world points on a and b
  float3 ra, rb;  // arms from the body origins
};

ContactPoints contact_points(Contact c) {
  ContactPoints p;
  p.pa = to_world(c.bodies.x, c.anchor_a.xyz);
  p.pb = to_world(c.bodies.y, c.anchor_b.xyz);
  p.ra = p.pa - body_position(c.bodies.x);
  p.rb = p.pb - body_position(c.bodies.y);
  return p;
}

// the rotation of body b over the substep (as velocities are derived from it)
float3 substep_turn(uint b) {
  return b == CRESSIM_NONE ? float3(0, 0, 0) : quat_rotation_between(prev_rotations[b], rotations[b]);
}

// how far the material point at arm r of body b moved over the substep, to first order in the
// turn: the chord of a turning point would make a rolling ball slip
float3 substep_motion(uint b, float3 r) {
  if (b == CRESSIM_NONE) return float3(0, 0, 0);
  return positions[b].xyz - prev_positions[b].xyz + cross(substep_turn(b), r);
}

// After generation: each run of contacts between the same two bodies (either order) gets its
// length in its first contact's bodies.w (0 in the others), and the bodies' contact counts.
void mark_patches(ContactSink sink, uint b0, uint b1) {
  clear_deltas(b0, b1);
  uint first = sink.base;
  for (uint i = sink.base; i < sink.base + sink.count; ++i) {
    const uint2 p = contacts[i].bodies.xy, q = contacts[first].bodies.xy;
    if (i > sink.base && !all(p == q) && !all(p.yx == q)) first = i;
    contacts[i].bodies.w = 0;
    contacts[first].bodies.w += 1;
    count_contact(p.x);
    count_contact(p.y);
  }
}

// the centroid of patch `first` (world)
float3 patch_centroid(uint first) {
  float3 sum = float3(0, 0, 0);
  const uint n = contacts[first].bodies.w;
  for (uint i = first; i < first + n; ++i) {
    const ContactPoints p = contact_points(contacts[i]);
    sum += 0.5 * (p.pa + p.pb);
  }
  return sum / n;
}

// Static friction of a patch: its bodies' material points at the centroid are held where they
// were at the substep start, and their turn about the normal undone, within the Coulomb limits;
// a clamped patch slides, losing mu lambda_n / h of momentum per substep.
void solve_patch_friction(uint first) {
  Contact f = contacts[first];
  const uint a = f.bodies.x, b = f.bodies.y, count = f.bodies.w;
  const float3 n = f.normal.xyz;
  const float3 centre = patch_centroid(first);
  float limit = 0, twist_limit = 0;
  for (uint i = first; i < first + count; ++i) {
    const Contact c = contacts[i];
    const ContactPoints p = contact_points(c);
    const float l = c.material.w * c.anchor_a.w;
    limit += l;
    twist_limit += l * length(0.5 * (p.pa + p.pb) - centre);
  }
  const float3 ra = centre - body_position(a), rb = centre - body_position(b);
  const float3 slip = substep_motion(a, ra) - substep_motion(b, rb);
  const float3 tangential = slip - dot(slip, n) * n;
  const float t = length(tangential);
  float3 lambda_t = f.friction.xyz;
  if (t > 1e-9) {
    const float3 dir = tangential / t;
    const float w = positional_weight(a, ra, dir) + positional_weight(b, rb, dir);
    if (w > 0) lambda_t -= tangential / w;
  }
  const float lt = length(lambda_t);
  if (lt > limit) lambda_t *= limit / lt;
  move_body(a, lambda_t - f.friction.xyz, ra, 1);
  move_body(b, lambda_t - f.friction.xyz, rb, -1);

  const float twist = dot(substep_turn(a) - substep_turn(b), n), wt = angular_weight(a, n) + angular_weight(b, n);
  float lambda_twist = f.normal.w;
  if (wt > 0) lambda_twist = clamp(lambda_twist - twist / wt, -twist_limit, twist_limit);
  turn_body(a, (lambda_twist - f.normal.w) * n, 1);
  turn_body(b, (lambda_twist - f.normal.w) * n, -1);
  contacts[first].friction.xyz = lambda_t;
  contacts[first].normal.w = lambda_twist;
}

// positional correction `correction` of a against b, accumulated at the contact's share;
// returns the multiplier's change
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

void solve_contacts(ContactSink sink, uint b0, uint b1) {
  for (uint i = sink.base; i < sink.base + sink.count; ++i) {
    const Contact c = contacts[i];
    const ContactPoints p = contact_points(c);
    const float depth = dot(p.pb - p.pa, c.normal.xyz);
    if (depth <= 0) continue;
    contacts[i].anchor_a.w += accumulate_position(c.bodies.x, c.bodies.y, p.ra, p.rb, depth * c.normal.xyz,
                                                  contact_share(c.bodies.x, c.bodies.y));
  }
  apply_position_deltas(b0, b1);
  // patches sharing a body (a box pinched between two jaws) need a few sweeps to share the load;
  // alternating the direction favours none
  for (uint s = 0; s < FRICTION_SWEEPS; ++s) {
    if ((s & 1) == 0) {
      for (uint i = sink.base; i < sink.base + sink.count; i += contacts[i].bodies.w) solve_patch_friction(i);
    } else {
      for (uint i = sink.base + sink.count; i > sink.base;) {
        uint first = i - 1;
        while (contacts[first].bodies.w == 0) --first;
        solve_patch_friction(first);
        i = first;
      }
    }
  }
}

// After velocities are derived from positions: a contact that pushed this substep ends with no
// approach (or the restitution's rebound when it hit faster than the rest speed), as its share
// of an impulse. Friction is not repeated here: the positional friction already took its momentum.
void solve_contact_velocities(ContactSink sink, uint b0, uint b1) {
  for (uint i = sink.base; i < sink.base + sink.count; ++i) {
    const Contact c = contacts[i];
    if (c.anchor_a.w <= 0) continue;
    const uint a = c.bodies.x, b = c.bodies.y;
    const float3 n = c.normal.xyz;
    const ContactPoints p = contact_points(c);
    const float wn = positional_weight(a, p.ra, n) + positional_weight(b, p.rb, n);
    if (wn <= 0) continue;
    const float vn = dot(n, point_velocity(a, p.ra) - point_velocity(b, p.rb));
    const float vn_before = c.anchor_b.w;
    const float e = abs(vn_before) <= rest_speed() ? 0 : c.material.z;
    const float impulse = contact_share(a, b) * (max(-e * vn_before, 0.0) - vn) / wn;
    accumulate(a, impulse * n, p.ra, 1);
    accumulate(b, impulse * n, p.rb, -1);
    contacts[i].friction.w = impulse;
  }
  apply_velocity_deltas(b0, b1);
}

// Contact force and torque (about the body origin) on each body, summed over the substeps:
// positional multipliers are impulses over h^2, velocity-level ones over h; a patch's friction
// acts at its centroid.
void add_force(uint b, float3 f, float3 arm, float3 torque) {
  if (b == CRESSIM_NONE) return;
  contact_forces[b].xyz += f;
  contact_torques[b].xyz += cross(arm, f) + torque;
}

void add_contact_forces(ContactSink sink, float h) {
  for (uint i = sink.base; i < sink.base + sink.count; ++i) {
    const Contact c = contacts[i];
    const uint a = c.bodies.x, b = c.bodies.y;
    const ContactPoints p = contact_points(c);
    const float3 f = c.anchor_a.w * c.normal.xyz / (h * h) + c.friction.w * c.normal.xyz / h;
    add_force(a, f, p.ra, float3(0, 0, 0));
    add_force(b, -f, p.rb, float3(0, 0, 0));
    if (c.bodies.w == 0) continue;
    const float3 centre = patch_centroid(i), ft = c.friction.xyz / (h * h), twist = c.normal.w * c.normal.xyz / (h * h);
    add_force(a, ft, centre - body_position(a), twist);
    add_force(b, -ft, centre - body_position(b), -twist);
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

  // a body switched between kinematic and dynamic (a needle let go of, taken again) from here on;
  // one without a mass stays kinematic
  for (uint b = b0; b < b1; ++b) {
    const bool kinematic = body_kinematic[b] != 0 || dynamic_inertia[b].w <= 0;
    if (kinematic == ((bodies[b].ids.z & BODY_KINEMATIC) != 0)) continue;
    bodies[b].ids.z = kinematic ? bodies[b].ids.z | BODY_KINEMATIC : bodies[b].ids.z & ~BODY_KINEMATIC;
    bodies[b].inv_inertia = kinematic ? float4(0, 0, 0, 0) : dynamic_inertia[b];
  }
  for (uint b = b0; b < b1; ++b) {
    contact_forces[b] = float4(0, 0, 0, 0);
    contact_torques[b] = float4(0, 0, 0, 0);
  }
  for (uint j = j0; j < j1; ++j) {
    reaction_forces[j] = float4(0, 0, 0, 0);
    reaction_torques[j] = float4(0, 0, 0, 0);
  }
  // an env of kinematic and static bodies alone (an arm posed by FK over tissue) has no rigid
  // contacts to find: the pair loop, every substep, was a long serial chain of loads in one thread
  bool moving = false;
  for (uint b = b0; b < b1; ++b) moving = moving || is_dynamic(b);
  for (uint s = 0; s < pc.substeps; ++s) {
    for (uint j = j0; j < j1; ++j) {
      joint_velocities[j] = joint_coordinate(joints[j], joint_frames(joints[j]));
      joint_lambdas[j] = float4(0, 0, 0, 0);
    }
    for (uint b = b0; b < b1; ++b) integrate(b, h, pc.substeps - s);
    if (moving) generate_contacts(r, sink);
    mark_patches(sink, b0, b1);
    for (uint it = 0; it < pc.iterations; ++it) {
      for (uint j = j0; j < j1; ++j) solve_joint(j, h, joint_velocities[j]);
      if (sink.count > 0) solve_contacts(sink, b0, b1);
    }
    for (uint b = b0; b < b1; ++b) update_velocity(b, h);
    if (sink.count > 0) {
      solve_contact_velocities(sink, b0, b1);
      add_contact_forces(sink, h);
    }
  }

  // frame averages of the forces
  const float per_substep = 1.0 / pc.substeps;
  for (uint b = b0; b < b1; ++b) {
    contact_forces[b] *= per_substep;
    contact_torques[b] *= per_substep;
  }
  for (uint j = j0; j < j1; ++j) {
    reaction_forces[j] *= per_substep;
    reaction_torques[j] *= per_substep;
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
