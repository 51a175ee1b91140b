#include "physics/particle_model.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <set>
#include <stdexcept>

#include "cressim/rigid.h"
#include "scene/authoring_error.h"

namespace cressim::physics {
namespace {

using scene::Vec3;
using shader::float4;
using shader::ParticleConstraint;
using shader::uint4;

constexpr uint32_t NONE = shader::CRESSIM_NONE;

Vec3 rotate(const scene::Quat& q0, const Vec3& v) {
  const float n = std::sqrt(q0[0] * q0[0] + q0[1] * q0[1] + q0[2] * q0[2] + q0[3] * q0[3]);
  const float x = q0[0] / n, y = q0[1] / n, z = q0[2] / n, w = q0[3] / n;
  // v + 2w (q x v) + 2 q x (q x v)
  const Vec3 t{2 * (y * v[2] - z * v[1]), 2 * (z * v[0] - x * v[2]), 2 * (x * v[1] - y * v[0])};
  return {v[0] + w * t[0] + y * t[2] - z * t[1], v[1] + w * t[1] + z * t[0] - x * t[2],
          v[2] + w * t[2] + x * t[1] - y * t[0]};
}

using Q = std::array<float, 4>;
float4 mul(const Q& a, const Q& b) {
  return {a[3] * b[0] + b[3] * a[0] + a[1] * b[2] - a[2] * b[1], a[3] * b[1] + b[3] * a[1] + a[2] * b[0] - a[0] * b[2],
          a[3] * b[2] + b[3] * a[2] + a[0] * b[1] - a[1] * b[0], a[3] * b[3] - a[0] * b[0] - a[1] * b[1] - a[2] * b[2]};
}
Q axis_angle(const Vec3& axis, float angle) {
  const float s = std::sin(0.5f * angle);
  return {axis[0] * s, axis[1] * s, axis[2] * s, std::cos(0.5f * angle)};
}
// the rotation taking +z onto the unit vector d (shortest arc)
Q from_z_to(const Vec3& d) {
  if (d[2] < -0.999999f) return {1, 0, 0, 0};  // half turn about x
  const Vec3 w{-d[1], d[0], 0};                // z cross d
  Q q{w[0], w[1], w[2], 1 + d[2]};
  const float n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  return {q[0] / n, q[1] / n, q[2] / n, q[3] / n};
}

float dist(const float4& a, const float4& b) {
  return std::sqrt((a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y) + (a.z - b.z) * (a.z - b.z));
}

[[noreturn]] void fail(const scene::World& w, scene::EntityId e, const std::string& what) {
  throw scene::AuthoringError(w, e, what);
}

// one object being added: its entity, env and where its particles start
struct Adding {
  const scene::World& world;
  scene::EntityId entity;
  uint32_t env, object, first;
};

// The constraint families, in solve order. A family is its name here, the records its builder
// below appends, and shaders/physics/particle_<name>.comp.hlsl; the solver (particle_system.cpp)
// makes buffers, cut flags, passes and dispatches from the set table without naming any family.
// Strand stretch goes last: solved along each strand, it has the final say on segment lengths.
constexpr const char* kConstraintFamilies[] = {"tet", "distance", "volume", "bend", "stretch_shear", "bend_twist",
                                               "stretch"};

class Builder {
 public:
  Builder(ParticleModel& m) : m_(m) {
    for (const char* name : kConstraintFamilies) {
      ConstraintSet s;
      s.name = name;
      s.shader = std::string("physics/particle_") + name;
      m_.sets.push_back(s);
    }
  }
  ConstraintSet& set(const char* name) {
    for (auto& s : m_.sets)
      if (s.name == name) return s;
    throw std::logic_error("no constraint set " + std::string(name));
  }

  // particles of an object at authored local positions, placed by the entity's transform
  uint32_t add_particles(const Adding& a, const std::vector<float>& local, uint32_t count, float inv_mass,
                         uint32_t kind, uint32_t flags, const char* field) {
    if (local.size() % 3) fail(a.world, a.entity, std::string(field) + " needs 3 numbers per particle");
    scene::Transform t = a.world.has<scene::Transform>(a.entity) ? a.world.get<scene::Transform>(a.entity) : scene::Transform{};
    for (uint32_t i = 0; i < count; ++i) {
      const bool authored = 3 * i < local.size();
      Vec3 p{0, 0, 0};
      if (authored) {
        const Vec3 s{local[3 * i] * t.scale[0], local[3 * i + 1] * t.scale[1], local[3 * i + 2] * t.scale[2]};
        p = rotate(t.rotation, s);
        p = {p[0] + t.position[0], p[1] + t.position[1], p[2] + t.position[2]};
        for (float c : p)
          if (!std::isfinite(c)) fail(a.world, a.entity, std::string(field) + "[" + std::to_string(i) + "] is not finite");
      }
      m_.positions.push_back({p[0], p[1], p[2], inv_mass});
      m_.velocities.push_back({0, 0, 0, 0});
      m_.phases.push_back({kind, a.object, a.env, (authored ? shader::PARTICLE_ACTIVE : 0u) | flags});
    }
    return count;
  }

  void constraint(ConstraintSet& s, std::initializer_list<uint32_t> ids, float rest, float compliance, float z = 0) {
    ParticleConstraint c{};
    uint32_t p[4] = {NONE, NONE, NONE, NONE};
    int k = 0;
    for (uint32_t i : ids) p[k++] = i;
    c.particles = {p[0], p[1], p[2], p[3]};
    c.params = {rest, compliance, z, 0};
    s.records.push_back(c);
  }

  void distance(uint32_t i, uint32_t j, float compliance) {
    const float l = dist(m_.positions[i], m_.positions[j]);
    if (l > 1e-9f) constraint(set("distance"), {i, j}, l, compliance);
  }

  void fix(const Adding& a, const std::vector<uint32_t>& fixed, uint32_t count, const char* field) {
    for (uint32_t i : fixed) {
      if (i >= count) fail(a.world, a.entity, std::string(field) + " names particle " + std::to_string(i) + " of " + std::to_string(count));
      m_.positions[a.first + i].w = 0;
    }
  }

  float signed_volume(const uint32_t q[4]) const {
    const float4 &x0 = m_.positions[q[0]], &x1 = m_.positions[q[1]], &x2 = m_.positions[q[2]], &x3 = m_.positions[q[3]];
    const Vec3 e1{x1.x - x0.x, x1.y - x0.y, x1.z - x0.z}, e2{x2.x - x0.x, x2.y - x0.y, x2.z - x0.z},
        e3{x3.x - x0.x, x3.y - x0.y, x3.z - x0.z};
    return (e1[0] * (e2[1] * e3[2] - e2[2] * e3[1]) - e1[1] * (e2[0] * e3[2] - e2[2] * e3[0]) +
            e1[2] * (e2[0] * e3[1] - e2[1] * e3[0])) / 6;
  }

  // Stable Neo-Hookean tets (Smith et al. 2018, without the log term): per unit rest volume
  //   psi = mu/2 (tr(F^T F) - 3) + lambda/2 (det F - alpha)^2,  alpha = 1 + mu / lambda,
  // whose small-strain limit is linear elasticity with Lame parameters mu and lambda - mu; so
  // lambda is the Lame lambda of (E, nu) plus mu. Each record keeps (V0, mu, lambda, alpha) and the
  // inverse rest shape matrix Dm^-1 (3 rows); each corner gets a quarter of the tet's mass.
  void elastic_tets(const Adding& a, const scene::SoftBody& sb, uint32_t n) {
    const double E = sb.youngs_modulus, nu = sb.poisson_ratio;
    const double mu = E / (2 * (1 + nu)), lame = E * nu / ((1 + nu) * (1 - 2 * nu)), lambda = lame + mu;
    std::vector<double> mass(n, 0.0), conductance(n, 0.0);
    auto& tets = set("tet");
    tets.rows_per_record = 3;
    for (size_t t = 0; t < sb.tets.size(); t += 4) {
      uint32_t q[4] = {a.first + sb.tets[t], a.first + sb.tets[t + 1], a.first + sb.tets[t + 2], a.first + sb.tets[t + 3]};
      float vol = signed_volume(q);
      if (!(std::abs(vol) > 1e-18f)) fail(a.world, a.entity, "SoftBody.tets[" + std::to_string(t / 4) + "] has no volume");
      if (vol < 0) std::swap(q[2], q[3]), vol = -vol;
      // Dm = [x1 - x0, x2 - x0, x3 - x0] (columns), inverted in double
      double D[3][3];
      for (int c = 0; c < 3; ++c) {
        const float4 &xc = m_.positions[q[c + 1]], &x0 = m_.positions[q[0]];
        D[0][c] = double(xc.x) - x0.x, D[1][c] = double(xc.y) - x0.y, D[2][c] = double(xc.z) - x0.z;
      }
      const double det = D[0][0] * (D[1][1] * D[2][2] - D[1][2] * D[2][1]) - D[0][1] * (D[1][0] * D[2][2] - D[1][2] * D[2][0]) +
                         D[0][2] * (D[1][0] * D[2][1] - D[1][1] * D[2][0]);
      double B[3][3];
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) {
          // inverse = adjugate / det: B[r][c] = cofactor(c, r) / det
          const int r1 = (c + 1) % 3, r2 = (c + 2) % 3, c1 = (r + 1) % 3, c2 = (r + 2) % 3;
          B[r][c] = (D[r1][c1] * D[r2][c2] - D[r1][c2] * D[r2][c1]) / det;
        }
      constraint(tets, {q[0], q[1], q[2], q[3]}, vol, float(mu), float(lambda));
      tets.records.back().params.w = float(1 + mu / lambda);
      for (int r = 0; r < 3; ++r) tets.record_rows.push_back({float(B[r][0]), float(B[r][1]), float(B[r][2]), 0});
      for (uint32_t k : q) mass[k - a.first] += sb.density * vol / 4;
      if (sb.thermal.enabled)  // K_kk = k V0 |b_k|^2, b_0 = -(b_1 + b_2 + b_3)
        for (int k = 0; k < 4; ++k) {
          double g[3];
          for (int c = 0; c < 3; ++c) g[c] = k == 0 ? -(B[0][c] + B[1][c] + B[2][c]) : B[k - 1][c];
          conductance[q[k] - a.first] += sb.thermal.conductivity * vol * (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
        }
    }
    for (uint32_t i = 0; i < n; ++i) {
      if (!(mass[i] > 0))
        fail(a.world, a.entity, "SoftBody particle " + std::to_string(i) + " belongs to no tet (an elastic body's "
                                "mass comes from its tets)");
      m_.positions[a.first + i].w = float(1 / mass[i]);
      m_.phases[a.first + i].w |= shader::PARTICLE_ELASTIC;
      if (sb.thermal.enabled) {
        m_.heat_capacities.resize(m_.size(), 0.f);
        m_.heat_capacities[a.first + i] = float(mass[i] * sb.thermal.specific_heat);
        m_.heat_step_limit = std::min(m_.heat_step_limit, float(mass[i] * sb.thermal.specific_heat / conductance[i]));
      }
    }
    if (sb.thermal.enabled) m_.has_heat = true;
  }

  void soft_body(const Adding& a, const scene::SoftBody& sb) {
    const uint32_t n = uint32_t(sb.positions.size() / 3);
    const bool elastic = sb.youngs_modulus != 0;  // field values: scene/validate.cpp, before this
    add_particles(a, sb.positions, n, elastic ? 0.f : 1 / sb.mass, shader::PARTICLE_SOLID,
                  sb.self_collision ? shader::PARTICLE_SELF_COLLIDE : 0u, "SoftBody.positions");
    for (uint32_t v : sb.tets)
      if (v >= n) fail(a.world, a.entity, "SoftBody.tets names particle " + std::to_string(v) + " of " + std::to_string(n));
    for (uint32_t v : sb.triangles)
      if (v >= n) fail(a.world, a.entity, "SoftBody.triangles names particle " + std::to_string(v) + " of " + std::to_string(n));
    if (elastic) {
      elastic_tets(a, sb, n);
      fix(a, sb.fixed, n, "SoftBody.fixed");
    } else if (!sb.tets.empty()) {
      fix(a, sb.fixed, n, "SoftBody.fixed");
      // every tet edge once, and every tet's volume
      std::set<std::pair<uint32_t, uint32_t>> edges;
      for (size_t t = 0; t < sb.tets.size(); t += 4)
        for (int i = 0; i < 4; ++i)
          for (int j = i + 1; j < 4; ++j) edges.insert(std::minmax(sb.tets[t + i], sb.tets[t + j]));
      for (auto [i, j] : edges) distance(a.first + i, a.first + j, sb.distance_compliance);
      for (size_t t = 0; t < sb.tets.size(); t += 4) {
        const uint32_t q[4] = {a.first + sb.tets[t], a.first + sb.tets[t + 1], a.first + sb.tets[t + 2], a.first + sb.tets[t + 3]};
        const float vol = signed_volume(q);
        if (std::abs(vol) < 1e-15f) fail(a.world, a.entity, "SoftBody.tets[" + std::to_string(t / 4) + "] has no volume");
        if (vol > 0) constraint(set("volume"), {q[0], q[1], q[2], q[3]}, vol, sb.volume_compliance);
        else constraint(set("volume"), {q[0], q[1], q[3], q[2]}, -vol, sb.volume_compliance);
      }
    } else {
      fix(a, sb.fixed, n, "SoftBody.fixed");
      // meshfree: k nearest neighbours (each pair once)
      if (sb.neighbors < 1) fail(a.world, a.entity, "SoftBody.neighbors must be at least 1 for a meshfree body");
      std::set<std::pair<uint32_t, uint32_t>> pairs;
      std::vector<std::pair<float, uint32_t>> d(n);
      for (uint32_t i = 0; i < n; ++i) {
        for (uint32_t j = 0; j < n; ++j) d[j] = {i == j ? INFINITY : dist(m_.positions[a.first + i], m_.positions[a.first + j]), j};
        const uint32_t k = std::min(sb.neighbors, n - 1);
        std::partial_sort(d.begin(), d.begin() + k, d.end());
        for (uint32_t r = 0; r < k; ++r) pairs.insert(std::minmax(i, d[r].second));
      }
      for (auto [i, j] : pairs) distance(a.first + i, a.first + j, sb.distance_compliance);
    }
    surface(sb.triangles, a.first);
  }

  void fluid(const Adding& a, const scene::Fluid& f) {
    const uint32_t active = uint32_t(f.positions.size() / 3), budget = f.budget ? f.budget : active;
    if (budget == 0) fail(a.world, a.entity, "Fluid has no particles (give positions or a budget)");
    if (active > budget) fail(a.world, a.entity, "Fluid.budget " + std::to_string(budget) + " is below its " + std::to_string(active) + " positions");
    if (!(f.radius > 0)) fail(a.world, a.entity, "Fluid.radius must be positive");
    if (!(f.rest_density > 0)) fail(a.world, a.entity, "Fluid.rest_density must be positive");
    add_particles(a, f.positions, budget, 1 / fluid_particle_mass(f.radius, f.rest_density), shader::PARTICLE_FLUID, 0,
                  "Fluid.positions");
    m_.has_fluid = true;
  }

  void strand(const Adding& a, const scene::Strand& s) {
    const uint32_t n = uint32_t(s.points.size() / 3);
    if (n < 2) fail(a.world, a.entity, "Strand.points needs at least 2 points");
    if (!(s.mass > 0)) fail(a.world, a.entity, "Strand.mass must be positive");
    if (!(s.radius > 0)) fail(a.world, a.entity, "Strand.radius must be positive");
    add_particles(a, s.points, n, 1 / s.mass, shader::PARTICLE_STRAND,
                  (s.self_collision ? shader::PARTICLE_SELF_COLLIDE : 0u) |
                      (s.soft_body_contacts ? 0u : shader::PARTICLE_NO_SOFT_CONTACT),
                  "Strand.points");
    // a rod of a material: density x volume lumped to the particles (half of each segment to each
    // end), bending EI and twist GJ of a solid round section, E I = E pi r^4 / 4, G J = G pi r^4 / 2
    const bool rod = s.youngs_modulus > 0;
    const double area = std::numbers::pi * double(s.radius) * s.radius, I = area * s.radius * s.radius / 4;
    const double EI = s.youngs_modulus * I, GJ = s.youngs_modulus / (2 * (1 + s.poisson_ratio)) * 2 * I;
    std::vector<double> seg_mass(n, 0.0);
    if (rod) {
      for (uint32_t i = 0; i + 1 < n; ++i) {
        const double half = 0.5 * s.density * area * dist(m_.positions[a.first + i], m_.positions[a.first + i + 1]);
        seg_mass[i] += half, seg_mass[i + 1] += half;
      }
      for (uint32_t i = 0; i < n; ++i) m_.positions[a.first + i].w = float(1 / seg_mass[i]);
    }
    fix(a, s.fixed, n, "Strand.fixed");
    // segment lengths: one chain per strand, solved directly along it (particle_stretch.comp.hlsl)
    auto& stretch = set("stretch");
    stretch.chains.insert(stretch.chains.end(), {uint32_t(stretch.records.size()), n - 1});
    for (uint32_t p = a.first; p + 1 < a.first + n; ++p)
      constraint(stretch, {p, p + 1}, dist(m_.positions[p], m_.positions[p + 1]), s.stretch_compliance);
    // bending toward straight (threads and cables rest straight, whatever their authored path);
    // a rod of a material bends by its frames alone (bend_twist below carries E I)
    for (uint32_t i = 0; i + 2 < n && !rod; ++i) {
      const uint32_t p = a.first + i;
      const float seg = 0.5f * (dist(m_.positions[p], m_.positions[p + 1]) + dist(m_.positions[p + 1], m_.positions[p + 2]));
      constraint(set("bend"), {p, p + 1, p + 2}, 0, s.bend_compliance, seg);
    }
    // segment frames: z along the segment, turned about it by the initial twist; ids after the particles
    const uint32_t first_edge = uint32_t(m_.orientations.size());
    for (uint32_t i = 0; i + 1 < n; ++i) {
      const uint32_t p = a.first + i;
      const float4 &x0 = m_.positions[p], &x1 = m_.positions[p + 1];
      const float l = dist(x0, x1);
      if (l < 1e-9f) fail(a.world, a.entity, "Strand.points[" + std::to_string(i) + "] and the next coincide");
      const Vec3 d{(x1.x - x0.x) / l, (x1.y - x0.y) / l, (x1.z - x0.z) / l};
      const float twist = n > 2 ? s.initial_twist * float(i) / float(n - 2) : 0;
      m_.orientations.push_back(mul(axis_angle(d, twist), from_z_to(d)));
      // a thread's frame turns with the inertia of a thin rod about its axis, m r^2 / 2; a rod of
      // a material's with its segment's about a cross axis, m (3 r^2 + l^2) / 12, raised to what one
      // substep resolves (ParticleSystem::frame_weights); a segment between two fixed particles is
      // clamped, its frame too (the base of a cantilever)
      const double seg = s.density * area * l;
      const bool clamped = x0.w == 0 && x1.w == 0;
      m_.orientation_weights.push_back(clamped ? 0.f
                                       : rod   ? float(12 / (seg * (3.0 * s.radius * s.radius + double(l) * l)))
                                               : 2 / (s.mass * s.radius * s.radius));
      m_.frame_bend_compliances.push_back(rod ? float(l / (4 * EI)) : 0.f);
      m_.edge_particles.push_back(p);
      frames_.push_back({p, p + 1, first_edge + i, l});
    }
    for (uint32_t i = 0; i + 2 < n; ++i) {
      float bend = s.bend_compliance, twist = s.twist_compliance;
      if (rod) {
        // C = Im(q_i* q_i+1) is sin(theta / 2) for a turn theta between the frames, so C^2 / 2 alpha
        // is the rod's E I theta^2 / 2 l over the length l the turn is spread on when alpha = l / 4 E I
        const float4 &x0 = m_.positions[a.first + i], &x1 = m_.positions[a.first + i + 1], &x2 = m_.positions[a.first + i + 2];
        const double l = 0.5 * (dist(x0, x1) + dist(x1, x2));
        bend = float(l / (4 * EI)), twist = float(l / (4 * GJ));
      }
      pairs_.push_back({first_edge + i, first_edge + i + 1, bend, twist});
    }
  }

  // A Tendons component on a strand just added (its particles from `first`, frames from
  // `first_edge`): each disk turns with the frame of the segment that starts at its particle (the
  // last particle's, with the last segment); a tendon's rest length is its route through the
  // holes as authored.
  void tendons(const Adding& a, const scene::Tendons& t, uint32_t first, uint32_t count, uint32_t first_edge) {
    shader::TendonRobot robot{};
    robot.range = {uint32_t(m_.tendon_disks.size() / 2), uint32_t(t.disks.size()), uint32_t(m_.tendons.size()),
                   uint32_t(t.holes.size() / 2)};
    for (uint32_t k : t.disks) {
      if (k >= count) fail(a.world, a.entity, "Tendons.disks names particle " + std::to_string(k) + " of the Strand's " + std::to_string(count));
      m_.tendon_disks.insert(m_.tendon_disks.end(), {first + k, first_edge + std::min(k, count - 2)});
    }
    for (size_t j = 0; j < t.holes.size(); j += 2) {
      double length = 0;
      Vec3 prev{};
      for (size_t d = 0; d < t.disks.size(); ++d) {
        const float4& x = m_.positions[first + t.disks[d]];
        const float4& q = m_.orientations[first_edge + std::min(t.disks[d], count - 2)];
        const Vec3 o = rotate({q.x, q.y, q.z, q.w}, {t.holes[j], t.holes[j + 1], 0});
        const Vec3 h{x.x + o[0], x.y + o[1], x.z + o[2]};
        if (d) length += std::sqrt((h[0] - prev[0]) * (h[0] - prev[0]) + (h[1] - prev[1]) * (h[1] - prev[1]) + (h[2] - prev[2]) * (h[2] - prev[2]));
        prev = h;
      }
      shader::Tendon td{};
      td.route = {t.holes[j], t.holes[j + 1], float(length), t.stiffness > 0 ? float(length / t.stiffness) : 0.f};
      td.ids = {uint32_t(m_.tendon_robots.size()), a.env, 0, 0};
      m_.tendons.push_back(td);
    }
    m_.tendon_robots.push_back(robot);
  }

  // records that name frames can be made once the particle count is known
  void frame_constraints() {
    const uint32_t np = uint32_t(m_.size());
    // stretch-shear: one chain per strand, solved directly along it (particle_stretch_shear.comp.hlsl)
    auto& ss = set("stretch_shear");
    for (size_t i = 0; i < frames_.size(); ++i) {
      const auto& f = frames_[i];
      if (i == 0 || frames_[i - 1].p1 != f.p0) ss.chains.insert(ss.chains.end(), {uint32_t(ss.records.size()), 0u});
      constraint(ss, {f.p0, f.p1, np + f.edge}, f.length, 0);
      ++ss.chains.back();
    }
    // bend-twist: one chain per strand, solved directly along it (three multipliers a record: x, y
    // bending, z twist); Gauss-Seidel by colours leaves an over-constrained chain (a cable turned
    // at both held ends) twisted in alternate pairs instead of evenly
    auto& bt = set("bend_twist");
    bt.multipliers = 3;
    for (size_t i = 0; i < pairs_.size(); ++i) {
      const auto& b = pairs_[i];
      if (i == 0 || pairs_[i - 1].e1 != b.e0) bt.chains.insert(bt.chains.end(), {uint32_t(bt.records.size()), 0u});
      constraint(bt, {np + b.e0, np + b.e1}, b.bend, b.twist);
      ++bt.chains.back();
    }
  }

  void surface(const std::vector<uint32_t>& tris, uint32_t first) {
    for (uint32_t v : tris) m_.surface.push_back(first + v);
  }

 private:
  struct Frame { uint32_t p0, p1, edge; float length; };
  struct FramePair { uint32_t e0, e1; float bend, twist; };
  ParticleModel& m_;
  std::vector<Frame> frames_;
  std::vector<FramePair> pairs_;
};

// greedy colouring: each constraint takes the lowest colour none of its particles has yet;
// records are then grouped by colour (stable, so objects and envs keep their order inside one)
void colour(ConstraintSet& s, size_t particles) {
  std::vector<std::vector<bool>> used(particles);
  std::vector<uint32_t> colour_of(s.records.size());
  uint32_t colours = 0;
  for (size_t c = 0; c < s.records.size(); ++c) {
    const uint32_t* p = &s.records[c].particles.x;
    uint32_t k = 0;
    auto taken = [&](uint32_t k) {
      for (int i = 0; i < 4; ++i)
        if (p[i] != NONE && k < used[p[i]].size() && used[p[i]][k]) return true;
      return false;
    };
    while (taken(k)) ++k;
    for (int i = 0; i < 4; ++i)
      if (p[i] != NONE) {
        if (used[p[i]].size() <= k) used[p[i]].resize(k + 1, false);
        used[p[i]][k] = true;
      }
    colour_of[c] = k;
    colours = std::max(colours, k + 1);
  }
  s.colour_count.assign(colours, 0);
  for (uint32_t k : colour_of) ++s.colour_count[k];
  s.colour_offset.assign(colours, 0);
  for (uint32_t k = 1; k < colours; ++k) s.colour_offset[k] = s.colour_offset[k - 1] + s.colour_count[k - 1];
  std::vector<ParticleConstraint> sorted(s.records.size());
  std::vector<uint32_t> cursor = s.colour_offset;
  for (size_t c = 0; c < s.records.size(); ++c) sorted[cursor[colour_of[c]]++] = s.records[c];
  s.records = std::move(sorted);
}

// vertex-solved families: colour the particles so that no two of a colour share a record
// (greedy, lowest free colour), group them by colour and list each one's (record, corner)s
void colour_vertices(ConstraintSet& s, size_t particles) {
  std::vector<std::vector<uint32_t>> corners(particles);
  for (uint32_t r = 0; r < s.records.size(); ++r) {
    const auto& p = s.records[r].particles;
    const uint32_t ids[4] = {p.x, p.y, p.z, p.w};
    for (uint32_t k = 0; k < 4; ++k) corners[ids[k]].push_back(r * 4 + k);
  }
  std::vector<uint32_t> colour_of(particles, NONE);
  std::vector<uint32_t> used;  // used[c] == i: colour c is taken by a neighbour of particle i
  uint32_t colours = 0;
  for (uint32_t i = 0; i < particles; ++i) {
    if (corners[i].empty()) continue;
    used.resize(colours + 1, NONE);
    for (uint32_t rc : corners[i]) {
      const auto& p = s.records[rc / 4].particles;
      for (uint32_t j : {p.x, p.y, p.z, p.w})
        if (colour_of[j] != NONE) used[colour_of[j]] = i;
    }
    uint32_t k = 0;
    while (used[k] == i) ++k;
    colour_of[i] = k;
    colours = std::max(colours, k + 1);
  }
  s.vertex_colour_count.assign(colours, 0);
  for (uint32_t i = 0; i < particles; ++i)
    if (colour_of[i] != NONE) ++s.vertex_colour_count[colour_of[i]];
  s.vertex_colour_offset.assign(colours, 0);
  for (uint32_t k = 1; k < colours; ++k) s.vertex_colour_offset[k] = s.vertex_colour_offset[k - 1] + s.vertex_colour_count[k - 1];
  std::vector<uint32_t> cursor = s.vertex_colour_offset;
  s.vertices.assign(cursor.empty() ? 0 : cursor.back() + s.vertex_colour_count.back(), 0);
  for (uint32_t i = 0; i < particles; ++i)
    if (colour_of[i] != NONE) s.vertices[cursor[colour_of[i]]++] = i;
  s.vertex_records.clear();
  s.vertex_corners.clear();
  for (uint32_t i : s.vertices) {
    s.vertex_records.push_back(uint32_t(s.vertex_corners.size()));
    s.vertex_records.push_back(uint32_t(corners[i].size()));
    s.vertex_corners.insert(s.vertex_corners.end(), corners[i].begin(), corners[i].end());
  }
}

// each env's slice (first, count) of each colour in `s.env_colours`: items are built env by env
// and colouring keeps their order; `env_of(i)` is item i's env
template <class EnvOf>
void env_slices(ConstraintSet& s, const ParticleModel& m, const std::vector<uint32_t>& offset,
                const std::vector<uint32_t>& count, EnvOf env_of, const char* what) {
  const size_t envs = m.env_ranges.size(), colours = count.size();
  s.env_colours.assign(envs * colours * 2, 0);
  for (size_t k = 0; k < colours; ++k) {
    uint32_t last_env = 0;
    for (uint32_t i = offset[k]; i < offset[k] + count[k]; ++i) {
      const uint32_t env = env_of(i);
      if (env < last_env) throw std::logic_error(std::string(what) + " of " + s.name + " are not in env order");
      last_env = env;
      uint32_t* r = &s.env_colours[(env * colours + k) * 2];
      if (r[1] == 0) r[0] = i;
      ++r[1];
    }
  }
}

// records, by the env of their first particle (or of a strand frame's particle)
void env_colours(ConstraintSet& s, const ParticleModel& m) {
  env_slices(s, m, s.colour_offset, s.colour_count, [&](uint32_t c) {
    const uint32_t p = s.records[c].particles.x;
    return m.phases[p < m.size() ? p : m.edge_particles[p - m.size()]].z;
  }, "particle constraints");
}

// vertex-solved families: the solved particles listed per vertex colour in `vertices`
void env_vertex_colours(ConstraintSet& s, const ParticleModel& m) {
  env_slices(s, m, s.vertex_colour_offset, s.vertex_colour_count,
             [&](uint32_t v) { return m.phases[s.vertices[v]].z; }, "solved particles");
}

// the fluid passes' density kernel (shaders/physics/particle_fluid.hlsli)
float spiky(float r, float h) {
  if (r >= h) return 0;
  const float x = h - r;
  return 15.f / (std::numbers::pi_v<float> * std::pow(h, 6.f)) * x * x * x;
}

}  // namespace

float fluid_support(float radius) { return 4 * radius; }

// the mass that gives a particle on the rest lattice (spacing 2r) exactly the rest density
float fluid_particle_mass(float radius, float rest_density) {
  const float d = 2 * radius, h = fluid_support(radius);
  double sum = 0;
  for (int i = -3; i <= 3; ++i)
    for (int j = -3; j <= 3; ++j)
      for (int k = -3; k <= 3; ++k) sum += spiky(d * std::sqrt(float(i * i + j * j + k * k)), h);
  return float(rest_density / sum);
}

const ConstraintSet* ParticleModel::set(const std::string& name) const {
  for (auto& s : sets)
    if (s.name == name) return &s;
  return nullptr;
}

ParticleModel build_particle_model(const scene::World& world, const scene::LayoutMapping& mapping) {
  ParticleModel m;
  Builder b(m);
  m.env_ranges.resize(mapping.num_envs);
  float max_radius = 0, max_support = 0;
  for (uint32_t env = 0; env < mapping.num_envs; ++env) {
    auto& range = m.env_ranges[env].range;
    range.x = uint32_t(m.size());
    range.z = uint32_t(m.objects.size());
    for (uint32_t row = mapping.env_offset[env]; row < mapping.env_offset[env] + mapping.env_count[env]; ++row) {
      const scene::EntityId e = mapping.row_entity[row];
      auto begin = [&](uint32_t kind) {
        shader::ParticleObject o{};
        o.range = {uint32_t(m.size()), 0, env, kind};
        o.ids = {row, 0, 0, 0};
        m.objects.push_back(o);
        m.object_entity.push_back(e);
        m.surface_offset.push_back(uint32_t(m.surface.size() / 3));
        return Adding{world, e, env, uint32_t(m.objects.size() - 1), uint32_t(m.size())};
      };
      auto end = [&]() {
        auto& o = m.objects.back();
        o.range.y = uint32_t(m.size()) - o.range.x;
        m.surface_count.push_back(uint32_t(m.surface.size() / 3) - m.surface_offset.back());
      };
      if (world.has<scene::SoftBody>(e)) {
        const auto& sb = world.get<scene::SoftBody>(e);
        b.soft_body(begin(shader::PARTICLE_SOLID), sb);
        auto& o = m.objects.back();
        o.ids.y = sb.self_collision ? shader::PARTICLE_SELF_COLLIDE : 0u;
        o.material = {sb.radius, sb.friction, sb.damping, 0};
        if (sb.thermal.enabled) {
          const auto& t = sb.thermal;
          o.heat = {t.conductivity, t.specific_heat, t.temperature, sb.density};
          o.burn = {float(std::log(t.frequency_factor)), float(t.activation_energy / 8.314462618), t.damage_onset, 0};
          o.coagulation = {t.coagulated_stiffening, t.coagulated_shrinkage, 0, 0};
        }
        max_radius = std::max(max_radius, sb.radius);
        end();
      }
      if (world.has<scene::Fluid>(e)) {
        const auto& f = world.get<scene::Fluid>(e);
        b.fluid(begin(shader::PARTICLE_FLUID), f);
        auto& o = m.objects.back();
        o.ids.z = uint32_t(m.size()) - o.range.x;
        o.ids.w = uint32_t(f.positions.size() / 3);
        o.material = {f.radius, f.friction, f.damping, f.rest_density};
        o.fluid = {f.viscosity, f.cohesion, f.surface_tension, f.vorticity};
        if (f.emit_rate > 0) {
          if (f.emit_width < 1) fail(world, e, "Fluid.emit_width must be at least 1");
          const scene::Transform t = world.has<scene::Transform>(e) ? world.get<scene::Transform>(e) : scene::Transform{};
          const Vec3 local{f.emit_origin[0] * t.scale[0], f.emit_origin[1] * t.scale[1], f.emit_origin[2] * t.scale[2]};
          const Vec3 c = rotate(t.rotation, local);
          const Vec3& v = f.emit_velocity;
          if (!(v[0] * v[0] + v[1] * v[1] + v[2] * v[2] > 0)) fail(world, e, "Fluid.emit_velocity must not be zero");
          o.emitter = {c[0] + t.position[0], c[1] + t.position[1], c[2] + t.position[2], float(f.emit_rate)};
          o.emit_velocity = {v[0], v[1], v[2], float(f.emit_width)};
          m.has_emitters = true;
        }
        max_radius = std::max(max_radius, f.radius);
        max_support = std::max(max_support, fluid_support(f.radius));
        end();
      }
      if (world.has<scene::Strand>(e)) {
        const auto& s = world.get<scene::Strand>(e);
        const Adding& added = begin(shader::PARTICLE_STRAND);
        b.strand(added, s);
        if (world.has<scene::Tendons>(e)) {
          const uint32_t count = uint32_t(s.points.size() / 3);
          b.tendons(added, world.get<scene::Tendons>(e), added.first, count, uint32_t(m.orientations.size()) - (count - 1));
        }
        auto& o = m.objects.back();
        o.ids.y = s.self_collision ? shader::PARTICLE_SELF_COLLIDE : 0u;
        o.material = {s.radius, s.friction, s.damping, 0};
        max_radius = std::max(max_radius, s.radius);
        end();
      }
    }
    range.y = uint32_t(m.size()) - range.x;
    range.w = uint32_t(m.objects.size()) - range.z;
    // suture needles: the env's soft-body surface (its objects' triangles are contiguous) and the thread
    for (uint32_t row = mapping.env_offset[env]; row < mapping.env_offset[env] + mapping.env_count[env]; ++row) {
      const scene::EntityId e = mapping.row_entity[row];
      if (!world.has<scene::Needle>(e)) continue;
      const auto& n = world.get<scene::Needle>(e);
      shader::NeedleModel nm{};
      nm.ids = {uint32_t(e), NONE, 0, env};
      if (n.thread >= 0)
        for (uint32_t o = range.z; o < range.z + range.w; ++o)
          if (m.object_entity[o] == scene::EntityId(n.thread)) nm.ids.y = m.objects[o].range.x, nm.ids.z = m.objects[o].range.y;
      // the thread's first particle goes where the tail is (particle_needle_solve): driven, like a
      // fixed particle, so the strand's own solves take it as an anchor
      if (nm.ids.y != NONE) m.positions[nm.ids.y].w = 0;
      const uint32_t tri_first = range.w ? m.surface_offset[range.z] : uint32_t(m.surface.size() / 3);
      nm.records = {m.puncture_records, n.max_punctures, tri_first, uint32_t(m.surface.size() / 3) - tri_first};
      nm.arc = {n.arc_radius, n.arc_angle, n.puncture_force, n.friction};
      nm.puncture = {n.puncture_depth, n.squeeze, 0, 0};
      nm.center = {n.center[0], n.center[1], n.center[2], 0};
      const float qn = std::sqrt(n.rotation[0] * n.rotation[0] + n.rotation[1] * n.rotation[1] + n.rotation[2] * n.rotation[2] +
                                 n.rotation[3] * n.rotation[3]);
      nm.rotation = {n.rotation[0] / qn, n.rotation[1] / qn, n.rotation[2] / qn, n.rotation[3] / qn};
      m.needles.push_back(nm);
      m.puncture_records += n.max_punctures;
    }
  }
  if (m.has_heat) m.heat_capacities.resize(m.size(), 0.f);
  b.frame_constraints();
  // constraints per object: a record belongs to its first particle's object (or its first frame's strand)
  for (auto& s : m.sets) {
    s.object_count.assign(m.objects.size(), 0);
    for (auto& c : s.records) {
      const uint32_t p = c.particles.x < m.size() ? c.particles.x : m.edge_particles[c.particles.x - m.size()];
      ++s.object_count[m.phases[p].y];
    }
  }
  m.cell_size = std::max(max_support, 2 * max_radius);
  // particles of different objects (or of a self-colliding one) touch: the grid is needed
  for (auto& r : m.env_ranges) m.has_contacts = m.has_contacts || r.range.w > 1;
  for (auto& o : m.objects) m.has_contacts = m.has_contacts || (o.ids.y & shader::PARTICLE_SELF_COLLIDE);

  for (auto& s : m.sets) {
    if (s.rows_per_record) {  // vertex-solved: particles are coloured, records stay in one colour
      colour_vertices(s, m.size());
      s.colour_offset = {0};
      s.colour_count = {uint32_t(s.records.size())};
      env_vertex_colours(s, m);
      continue;
    } else if (s.chains.empty()) {
      colour(s, m.size() + m.orientations.size());
    } else {  // chain order is kept: one colour of all records
      s.colour_offset = {0};
      s.colour_count = {uint32_t(s.records.size())};
    }
    env_colours(s, m);
  }
  return m;
}

}  // namespace cressim::physics
