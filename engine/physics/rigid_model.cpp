#include "physics/rigid_model.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "scene/authoring_error.h"

namespace cressim::physics {
namespace {

using scene::Vec3;
using scene::Quat;
using shader::float4;

// small pose algebra for authoring (the GPU has its own in quat.h)
struct Pose {
  Vec3 p{0, 0, 0};
  Quat q{0, 0, 0, 1};
};
Quat mul(const Quat& a, const Quat& b) {
  return {a[3] * b[0] + b[3] * a[0] + a[1] * b[2] - a[2] * b[1], a[3] * b[1] + b[3] * a[1] + a[2] * b[0] - a[0] * b[2],
          a[3] * b[2] + b[3] * a[2] + a[0] * b[1] - a[1] * b[0], a[3] * b[3] - a[0] * b[0] - a[1] * b[1] - a[2] * b[2]};
}
Quat conj(const Quat& q) { return {-q[0], -q[1], -q[2], q[3]}; }
Vec3 rotate(const Quat& q, const Vec3& v) {
  Quat r = mul(mul(q, {v[0], v[1], v[2], 0}), conj(q));
  return {r[0], r[1], r[2]};
}
Vec3 sub(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
float dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Quat normalized(Quat q) {
  float n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  return {q[0] / n, q[1] / n, q[2] / n, q[3] / n};
}
// the pose `world` seen from `frame`
Pose relative(const Pose& frame, const Pose& world) {
  return {rotate(conj(frame.q), sub(world.p, frame.p)), mul(conj(frame.q), world.q)};
}
// rotation taking +x onto the unit vector `axis`
Quat from_x_to(Vec3 axis) {
  const float n = std::sqrt(dot(axis, axis));
  axis = {axis[0] / n, axis[1] / n, axis[2] / n};
  const float c = axis[0];
  if (c < -0.999999f) return {0, 0, 1, 0};  // half turn about z
  const Vec3 w{0, -axis[2], axis[1]};      // x cross axis
  return normalized({w[0], w[1], w[2], 1 + c});
}
float4 f4(const Vec3& v, float w = 0) { return {v[0], v[1], v[2], w}; }
float4 f4(const Quat& q) { return {q[0], q[1], q[2], q[3]}; }

struct MassProperties {
  float mass = 0;
  Vec3 inertia{0, 0, 0};
};

// unit-density mass and inertia of a shape about the entity origin (principal axes assumed
// aligned with the entity frame: off-diagonal terms of rotated or offset shapes are dropped)
MassProperties unit_density(const scene::Shape& s) {
  const float pi = std::numbers::pi_v<float>;
  MassProperties m;
  Vec3 local{0, 0, 0};
  if (s.kind == scene::ShapeKind::SPHERE) {
    const float r = s.size[0];
    m.mass = 4.f / 3.f * pi * r * r * r;
    local = {0.4f * m.mass * r * r, 0.4f * m.mass * r * r, 0.4f * m.mass * r * r};
  } else if (s.kind == scene::ShapeKind::BOX) {
    const Vec3 h = s.size;
    m.mass = 8 * h[0] * h[1] * h[2];
    local = {m.mass / 3 * (h[1] * h[1] + h[2] * h[2]), m.mass / 3 * (h[0] * h[0] + h[2] * h[2]),
             m.mass / 3 * (h[0] * h[0] + h[1] * h[1])};
  } else if (s.kind == scene::ShapeKind::CAPSULE) {
    const float r = s.size[0], len = 2 * s.size[1];
    const float mc = pi * r * r * len, ms = 4.f / 3.f * pi * r * r * r;
    m.mass = mc + ms;
    const float lateral = mc * (len * len / 12 + r * r / 4) + ms * (0.4f * r * r + len * len / 4 + 0.375f * len * r);
    local = {lateral, lateral, 0.5f * mc * r * r + 0.4f * ms * r * r};
  }
  // rotate the principal moments into the entity frame (diagonal kept), then shift
  for (int i = 0; i < 3; ++i) {
    Vec3 e{0, 0, 0};
    e[i] = 1;
    const Vec3 el = rotate(conj(s.rotation), e);
    m.inertia[i] = local[0] * el[0] * el[0] + local[1] * el[1] * el[1] + local[2] * el[2] * el[2];
  }
  const Vec3& d = s.position;
  m.inertia[0] += m.mass * (d[1] * d[1] + d[2] * d[2]);
  m.inertia[1] += m.mass * (d[0] * d[0] + d[2] * d[2]);
  m.inertia[2] += m.mass * (d[0] * d[0] + d[1] * d[1]);
  return m;
}

Pose pose_of(const scene::World& w, scene::EntityId e) {
  if (!w.has<scene::Transform>(e)) return {};
  const auto& t = w.get<scene::Transform>(e);
  return {t.position, normalized(t.rotation)};
}

[[noreturn]] void fail(const scene::World& w, scene::EntityId e, const std::string& what) {
  throw scene::AuthoringError(w, e, what);
}

}  // namespace

RigidModel build_rigid_model(const scene::World& world, const scene::LayoutMapping& mapping) {
  RigidModel m;
  const size_t n_entities = world.entity_count();
  m.entity_body.assign(n_entities, -1);
  m.entity_joint.assign(n_entities, -1);
  m.env_ranges.resize(mapping.num_envs);

  for (uint32_t env = 0; env < mapping.num_envs; ++env) {
    const uint32_t first_row = mapping.env_offset[env], last_row = first_row + mapping.env_count[env];
    shader::EnvRigidRange& range = m.env_ranges[env];
    range.bodies.x = uint32_t(m.bodies.size());
    range.bodies.z = uint32_t(m.colliders.size());

    // bodies, then every collider of the env (body colliders and static ones)
    for (uint32_t row = first_row; row < last_row; ++row) {
      const scene::EntityId e = mapping.row_entity[row];
      if (!world.has<scene::RigidBody>(e)) continue;
      const auto& rb = world.get<scene::RigidBody>(e);
      MassProperties unit;
      if (world.has<scene::Collider>(e))
        for (const auto& s : world.get<scene::Collider>(e).shapes) {
          if (s.kind == scene::ShapeKind::PLANE) fail(world, e, "a plane can only be static (an entity without RigidBody)");
          MassProperties p = unit_density(s);
          unit.mass += p.mass;
          for (int i = 0; i < 3; ++i) unit.inertia[i] += p.inertia[i];
        }
      float mass = rb.mass > 0 ? rb.mass : rb.density * unit.mass;
      Vec3 inertia = rb.inertia;
      if (inertia == Vec3{0, 0, 0}) {
        if (unit.mass <= 0) fail(world, e, "RigidBody.inertia is not given and the entity has no collider shapes to compute it from");
        for (int i = 0; i < 3; ++i) inertia[i] = unit.inertia[i] * mass / unit.mass;
      }
      if (!rb.kinematic && !(mass > 0)) fail(world, e, "RigidBody.mass must be positive (or give collider shapes and a density)");
      for (int i = 0; i < 3; ++i)
        if (!rb.kinematic && !(inertia[i] > 0)) fail(world, e, "RigidBody.inertia must be positive on every axis");
      shader::BodyModel b{};
      const bool has_mass = mass > 0 && inertia[0] > 0 && inertia[1] > 0 && inertia[2] > 0;
      const shader::float4 inv = has_mass ? shader::float4{1 / inertia[0], 1 / inertia[1], 1 / inertia[2], 1 / mass}
                                          : shader::float4{0, 0, 0, 0};
      if (!rb.kinematic) b.inv_inertia = inv;
      m.dynamic_inertia.push_back(inv);
      m.kinematic.push_back(rb.kinematic ? 1u : 0u);
      b.damping = {rb.linear_damping, rb.angular_damping, 0, 0};
      b.ids = {row, env, rb.kinematic ? shader::BODY_KINEMATIC : 0u, 0};
      const Pose pose = pose_of(world, e);
      m.entity_body[e] = int64_t(m.bodies.size());
      m.bodies.push_back(b);
      m.initial_positions.push_back(f4(pose.p));
      m.initial_rotations.push_back(f4(pose.q));
      m.body_entity.push_back(e);
      m.body_env.push_back(env);
    }
    range.bodies.y = uint32_t(m.bodies.size()) - range.bodies.x;

    for (uint32_t row = first_row; row < last_row; ++row) {
      const scene::EntityId e = mapping.row_entity[row];
      if (!world.has<scene::Collider>(e)) continue;
      const auto& col = world.get<scene::Collider>(e);
      const int64_t body = m.entity_body[e];
      const Pose pose = pose_of(world, e);
      for (size_t i = 0; i < col.shapes.size(); ++i) {
        const auto& s = col.shapes[i];
        const std::string where = "Collider.shapes[" + std::to_string(i) + "]";
        if (s.kind == scene::ShapeKind::NONE) fail(world, e, where + " has no kind");
        if (s.kind != scene::ShapeKind::PLANE)
          for (int k = 0; k < (s.kind == scene::ShapeKind::BOX ? 3 : s.kind == scene::ShapeKind::CAPSULE ? 2 : 1); ++k)
            if (!(s.size[k] > 0)) fail(world, e, where + ".size must be positive");
        shader::ColliderModel c{};
        Pose local{s.position, normalized(s.rotation)};
        if (body < 0) {  // static: the shape frame in world
          const Vec3 off = rotate(pose.q, s.position);
          local.p = {pose.p[0] + off[0], pose.p[1] + off[1], pose.p[2] + off[2]};
          local.q = mul(pose.q, normalized(s.rotation));
        }
        c.position = f4(local.p);
        c.rotation = f4(local.q);
        c.size = f4(s.size);
        c.material = {col.static_friction, col.dynamic_friction, col.restitution, 0};
        c.ids = {body < 0 ? shader::CRESSIM_NONE : uint32_t(body), uint32_t(s.kind), col.group, col.mask};
        m.colliders.push_back(c);
      }
    }
    range.bodies.w = uint32_t(m.colliders.size()) - range.bodies.z;

    // joints, ordered so that a joint's parent body is placed before its child
    struct Pending {
      scene::EntityId e;
      shader::JointModel j;
      shader::float4 target;
      int depth;
    };
    std::vector<Pending> pending;
    auto body_index = [&](scene::EntityId joint_entity, int64_t ent, const char* field) -> uint32_t {
      if (ent < 0) return shader::CRESSIM_NONE;
      if (size_t(ent) >= n_entities) fail(world, joint_entity, std::string("Joint.") + field + " names no entity");
      if (world.env_of(scene::EntityId(ent)) != env)
        fail(world, joint_entity, std::string("Joint.") + field + " is " + world.describe(scene::EntityId(ent)) +
                                      ": a joint connects bodies of its own env");
      if (m.entity_body[ent] < 0)
        fail(world, joint_entity, std::string("Joint.") + field + " is " + world.describe(scene::EntityId(ent)) +
                                      ", which has no RigidBody");
      return uint32_t(m.entity_body[ent]);
    };
    for (uint32_t row = first_row; row < last_row; ++row) {
      const scene::EntityId e = mapping.row_entity[row];
      if (!world.has<scene::Joint>(e)) continue;
      const auto& jt = world.get<scene::Joint>(e);
      if (jt.kind == scene::JointKind::NONE) fail(world, e, "Joint.kind is not set");
      const uint32_t a = body_index(e, jt.body_a, "body_a"), b = body_index(e, jt.body_b, "body_b");
      if (b == shader::CRESSIM_NONE) fail(world, e, "Joint.body_b must be a rigid body");
      if (a == b) fail(world, e, "Joint.body_a and body_b are the same body");
      if (jt.limited && !(jt.lower <= jt.upper)) fail(world, e, "Joint limits need lower <= upper");
      if (dot(jt.axis, jt.axis) < 1e-12f) fail(world, e, "Joint.axis must not be zero");
      const Pose frame{jt.anchor, from_x_to(jt.axis)};
      const Pose pa = a == shader::CRESSIM_NONE ? Pose{} : pose_of(world, m.body_entity[a]);
      const Pose pb = pose_of(world, m.body_entity[b]);
      const Pose fa = relative(pa, frame), fb = relative(pb, frame);
      shader::JointModel j{};
      j.frame_a_position = f4(fa.p);
      j.frame_a_rotation = f4(fa.q);
      j.frame_b_position = f4(fb.p);
      j.frame_b_rotation = f4(fb.q);
      j.limits = {jt.lower, jt.upper, 0, 0};
      j.drive = {jt.stiffness, jt.damping, jt.max_force, jt.compliance};
      j.ids = {a, b, uint32_t(jt.kind), (jt.limited ? shader::JOINT_LIMITED : 0u) | (uint32_t(jt.drive) << 8)};
      const shader::float4 target = jt.kind == scene::JointKind::SPHERICAL ? f4(normalized(jt.target_rotation))
                                                                          : shader::float4{jt.target, 0, 0, 0};
      pending.push_back({e, j, target, 0});
      if (!jt.collide_connected && a != shader::CRESSIM_NONE) m.filtered_pairs.push_back({a, b});
    }
    // depth of a body = number of joints between it and the world (or a root body)
    std::vector<int> depth(m.bodies.size(), 0);
    for (size_t pass = 0; pass < pending.size(); ++pass)
      for (auto& p : pending)
        if (p.j.ids.x != shader::CRESSIM_NONE) depth[p.j.ids.y] = std::max(depth[p.j.ids.y], depth[p.j.ids.x] + 1);
    for (auto& p : pending) p.depth = p.j.ids.x == shader::CRESSIM_NONE ? -1 : depth[p.j.ids.x];
    std::stable_sort(pending.begin(), pending.end(), [](auto& x, auto& y) { return x.depth < y.depth; });
    range.joints.x = uint32_t(m.joints.size());
    for (auto& p : pending) {
      m.entity_joint[p.e] = int64_t(m.joints.size());
      m.joints.push_back(p.j);
      m.joint_targets.push_back(p.target);
      m.joint_entity.push_back(p.e);
    }
    range.joints.y = uint32_t(pending.size());
  }
  // filtered pairs are per env in body order; assign the ranges
  std::stable_sort(m.filtered_pairs.begin(), m.filtered_pairs.end(),
                   [&](auto& x, auto& y) { return m.body_env[x[0]] < m.body_env[y[0]]; });
  uint32_t k = 0;
  for (uint32_t env = 0; env < mapping.num_envs; ++env) {
    m.env_ranges[env].joints.z = k;
    while (k < m.filtered_pairs.size() && m.body_env[m.filtered_pairs[k][0]] == env) ++k;
    m.env_ranges[env].joints.w = k - m.env_ranges[env].joints.z;
  }
  return m;
}

}  // namespace cressim::physics
