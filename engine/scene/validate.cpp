#include "scene/validate.h"

#include <array>
#include <cmath>
#include <sstream>

#include "scene/authoring_error.h"

namespace cressim::scene {
namespace {

std::string show(double v) {
  std::ostringstream s;
  s << v;  // -1, 0.5, nan, inf
  return s.str();
}

// The checks of one component of one entity; a failure names "<Component>.<field>".
class Fields {
 public:
  Fields(const World& w, EntityId e, const char* component) : w_(w), e_(e), component_(component) {}

  const World& world() const { return w_; }
  EntityId entity() const { return e_; }

  [[noreturn]] void fail(const std::string& field, const std::string& problem) const {
    const std::string name = component_ + (field.empty() ? "" : "." + field);
    throw AuthoringError(w_, e_, name + (field.empty() ? ": " : " ") + problem, name);
  }
  void finite(const std::string& f, double v) const {
    if (!std::isfinite(v)) fail(f, "must be finite, got " + show(v));
  }
  void positive(const std::string& f, double v) const {
    if (!(v > 0) || !std::isfinite(v)) fail(f, "must be positive, got " + show(v));
  }
  void non_negative(const std::string& f, double v) const {
    if (!(v >= 0) || !std::isfinite(v)) fail(f, "must be >= 0, got " + show(v));
  }
  void within(const std::string& f, double v, double lo, double hi) const {
    if (!(v >= lo && v <= hi)) fail(f, "must be in [" + show(lo) + ", " + show(hi) + "], got " + show(v));
  }
  void at_least(const std::string& f, uint64_t v, uint64_t min) const {
    if (v < min) fail(f, "must be at least " + std::to_string(min) + ", got " + std::to_string(v));
  }
  template <size_t N>
  void finite(const std::string& f, const std::array<float, N>& v) const {
    for (size_t i = 0; i < N; ++i) finite(f + "[" + std::to_string(i) + "]", v[i]);
  }
  template <size_t N>
  void non_negative(const std::string& f, const std::array<float, N>& v) const {
    for (size_t i = 0; i < N; ++i) non_negative(f + "[" + std::to_string(i) + "]", v[i]);
  }
  // normalised where used, so any finite non-zero quaternion is a rotation
  void rotation(const std::string& f, const Quat& q) const {
    finite(f, q);
    if (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3] < 1e-12f)
      fail(f, "must be a non-zero quaternion (x, y, z, w)");
  }
  // x y z per point, all finite
  void points(const std::string& f, const std::vector<float>& xyz) const {
    if (xyz.size() % 3) fail(f, "needs 3 numbers per point, got " + std::to_string(xyz.size()) + " numbers");
    for (size_t i = 0; i < xyz.size(); ++i)
      if (!std::isfinite(xyz[i])) fail(f + "[" + std::to_string(i / 3) + "]", "must be finite, got " + show(xyz[i]));
  }
  void colour(const std::string& f, const std::array<float, 4>& rgba) const {
    non_negative(f, rgba);
    within(f + "[3]", rgba[3], 0, 1);
  }
  void index_list(const std::string& f, const std::vector<uint32_t>& v, size_t per, const char* what) const {
    if (v.size() % per)
      fail(f, "needs " + std::to_string(per) + " indices per " + what + ", got " + std::to_string(v.size()));
  }

 private:
  const World& w_;
  EntityId e_;
  std::string component_;
};

void transform(const Fields& c, const Transform& t) {
  c.finite("position", t.position);
  c.rotation("rotation", t.rotation);
  c.finite("scale", t.scale);
  for (int i = 0; i < 3; ++i)
    if (t.scale[i] == 0) c.fail("scale[" + std::to_string(i) + "]", "must not be 0");
}

void rigid_body(const Fields& c, const RigidBody& b) {
  if (!(b.mass >= 0) || !std::isfinite(b.mass))
    c.fail("mass", "must be >= 0 (0: density x the collider shapes' volume), got " + show(b.mass));
  if (b.mass == 0) c.positive("density", b.density);
  else c.non_negative("density", b.density);
  c.non_negative("inertia", b.inertia);
  c.non_negative("linear_damping", b.linear_damping);
  c.non_negative("angular_damping", b.angular_damping);
}

void collider(const Fields& c, const Collider& col) {
  for (size_t i = 0; i < col.shapes.size(); ++i) {
    const Shape& s = col.shapes[i];
    const std::string at = "shapes[" + std::to_string(i) + "]";
    // the sizes a kind reads: sphere radius; box half extents; capsule radius, half height
    int sizes = 0;
    switch (s.kind) {
      case ShapeKind::SPHERE: sizes = 1; break;
      case ShapeKind::BOX: sizes = 3; break;
      case ShapeKind::CAPSULE: sizes = 2; break;
      case ShapeKind::PLANE: break;
      default: c.fail(at + ".kind", "must be sphere, box, capsule or plane");
    }
    c.finite(at + ".size", s.size);
    for (int k = 0; k < sizes; ++k) c.positive(at + ".size[" + std::to_string(k) + "]", s.size[k]);
    c.finite(at + ".position", s.position);
    c.rotation(at + ".rotation", s.rotation);
  }
  c.non_negative("static_friction", col.static_friction);
  c.non_negative("dynamic_friction", col.dynamic_friction);
  c.within("restitution", col.restitution, 0, 1);
}

void joint(const Fields& c, const Joint& j) {
  if (j.kind == JointKind::NONE || uint32_t(j.kind) > uint32_t(JointKind::SLIDER))
    c.fail("kind", "must be fixed, ball, spherical, hinge or slider");
  c.finite("anchor", j.anchor);
  c.finite("axis", j.axis);
  if (j.axis[0] * j.axis[0] + j.axis[1] * j.axis[1] + j.axis[2] * j.axis[2] < 1e-12f) c.fail("axis", "must not be zero");
  if (j.limited) {
    c.finite("lower", j.lower);
    c.finite("upper", j.upper);
    if (!(j.lower <= j.upper)) c.fail("lower", "must be <= upper (" + show(j.lower) + " > " + show(j.upper) + ")");
  }
  if (uint32_t(j.drive) > uint32_t(DriveMode::VELOCITY)) c.fail("drive", "must be position or velocity");
  c.finite("target", j.target);
  c.rotation("target_rotation", j.target_rotation);
  c.non_negative("stiffness", j.stiffness);
  c.non_negative("damping", j.damping);
  if (!(j.max_force >= 0)) c.fail("max_force", "must be >= 0 (inf: unlimited), got " + show(j.max_force));
  c.non_negative("compliance", j.compliance);
}

void renderable(const Fields& c, const Renderable& r) {
  c.colour("color", r.color);
  c.within("metallic", r.metallic, 0, 1);
  c.within("roughness", r.roughness, 0, 1);
  if (r.texture < -1) c.fail("texture", "must be a texture index or -1, got " + std::to_string(r.texture));
  if (r.normal_map < -1) c.fail("normal_map", "must be a texture index or -1, got " + std::to_string(r.normal_map));
  c.finite("normal_scale", r.normal_scale);
}

void material(const Fields& c, const Material& m) {
  c.colour("color", m.color);
  c.within("metallic", m.metallic, 0, 1);
  c.within("roughness", m.roughness, 0, 1);
}

void camera(const Fields& c, const Camera& cam) {
  c.at_least("width", cam.width, 1);
  c.at_least("height", cam.height, 1);
  c.non_negative("fx", cam.fx);
  c.non_negative("fy", cam.fy);
  if (cam.fx == 0 && !(cam.fov_y > 0 && cam.fov_y < 180))
    c.fail("fov_y", "must be in (0, 180) degrees (or give fx), got " + show(cam.fov_y));
  c.finite("cx", cam.cx);
  c.finite("cy", cam.cy);
  c.positive("near", cam.near);
  c.positive("far", cam.far);
  if (!(cam.far > cam.near)) c.fail("far", "must be beyond near (" + show(cam.far) + " <= " + show(cam.near) + ")");
  if (cam.products == 0 || (cam.products & ~uint32_t(PRODUCT_ALL)))
    c.fail("products", "needs some of rgb, depth, segmentation");
}

void light(const Fields& c, const Light& l) {
  if (l.kind != LightKind::DIRECTIONAL && l.kind != LightKind::POINT && l.kind != LightKind::SPOT)
    c.fail("kind", "must be directional, point or spot");
  c.non_negative("color", l.color);
  c.non_negative("intensity", l.intensity);
  c.non_negative("ambient", l.ambient);
  c.non_negative("range", l.range);
  c.within("inner_angle", l.inner_angle, 0, 90);
  if (!(l.outer_angle > l.inner_angle && l.outer_angle < 90))
    c.fail("outer_angle", "must be in (inner_angle, 90) degrees, got " + show(l.outer_angle));
  if (l.shadows) {
    c.positive("shadow_extent", l.shadow_extent);
    if (l.shadow_resolution == 0 || l.shadow_resolution > 4096)
      c.fail("shadow_resolution", "must be in [1, 4096], got " + std::to_string(l.shadow_resolution));
  }
}

void environment_light(const Fields& c, const EnvironmentLight& l) {
  c.non_negative("sky", l.sky);
  c.non_negative("ground", l.ground);
  c.non_negative("intensity", l.intensity);
  if (l.map < -1) c.fail("map", "must be a texture index or -1, got " + std::to_string(l.map));
}

void ultrasound_probe(const Fields& c, const UltrasoundProbe& p) {
  if (p.kind == ProbeKind::LINEAR) {
    c.at_least("scanlines", p.scanlines, 1);
    c.positive("line_spacing", p.line_spacing);
  } else if (p.kind == ProbeKind::SECTOR) {
    c.at_least("scanlines", p.scanlines, 2);
    if (!(p.sector_angle > 0 && p.sector_angle < 180))
      c.fail("sector_angle", "must be in (0, 180) degrees, got " + show(p.sector_angle));
    c.non_negative("radius", p.radius);
  } else {
    c.fail("kind", "must be linear or sector");
  }
  c.positive("line_length", p.line_length);
  c.at_least("width", p.width, 1);
  c.at_least("height", p.height, 1);
  c.positive("sampling_frequency", p.sampling_frequency);
  c.at_least("radial_decimation", p.radial_decimation, 1);
  c.positive("center_frequency", p.center_frequency);
  c.positive("fractional_bandwidth", p.fractional_bandwidth);
  c.positive("lateral_beam_width", p.lateral_beam_width);
  c.positive("elevational_beam_width", p.elevational_beam_width);
  c.positive("speed_of_sound", p.speed_of_sound);
  c.positive("metres_per_unit", p.metres_per_unit);
  c.positive("dynamic_range", p.dynamic_range);
  c.finite("gain", p.gain);
  c.finite("time_gain_compensation", p.time_gain_compensation);
  c.non_negative("focal_depth", p.focal_depth);
  c.positive("coupling_impedance", p.coupling_impedance);
  c.non_negative("specular_amplitude", p.specular_amplitude);
}

void ultrasound_tissue(const Fields& c, const UltrasoundTissue& t) {
  // the sizes a region reads (a tissue on a SoftBody fills its tets and reads none)
  int sizes = 0;
  switch (t.region) {
    case RegionKind::BOX: sizes = 3; break;
    case RegionKind::SPHERE: sizes = 1; break;
    case RegionKind::CYLINDER: sizes = 2; break;
    default: c.fail("region", "must be box, sphere or cylinder");
  }
  c.finite("size", t.size);
  if (!c.world().has<SoftBody>(c.entity()))
    for (int k = 0; k < sizes; ++k) c.positive("size[" + std::to_string(k) + "]", t.size[k]);
  c.finite("center", t.center);
  c.non_negative("density", t.density);
  if ((t.density > 0) == (t.count > 0)) c.fail("", "give either density or count (> 0)");
  c.finite("amplitude_mean", t.amplitude_mean);
  c.non_negative("amplitude_std", t.amplitude_std);
  for (size_t i = 0; i < t.inclusions.size(); ++i) {
    const std::string at = "inclusions[" + std::to_string(i) + "]";
    c.finite(at + ".center", t.inclusions[i].center);
    c.positive(at + ".radius", t.inclusions[i].radius);
    c.non_negative(at + ".amplitude_scale", t.inclusions[i].amplitude_scale);
  }
  c.non_negative("attenuation", t.attenuation);
  c.positive("impedance", t.impedance);
}

void soft_body(const Fields& c, const SoftBody& s) {
  c.points("positions", s.positions);
  if (s.positions.empty()) c.fail("positions", "is empty");
  c.index_list("tets", s.tets, 4, "tet");
  c.index_list("triangles", s.triangles, 3, "triangle");
  if (s.youngs_modulus != 0) {  // the elastic material (youngs_modulus 0 selects the compliance model)
    if (s.tets.empty())
      c.fail("youngs_modulus", "needs tets (a meshfree body has no volume elements: give distance_compliance)");
    c.positive("youngs_modulus", s.youngs_modulus);
    if (!(s.poisson_ratio >= 0 && s.poisson_ratio < 0.5)) c.fail("poisson_ratio", "must be in [0, 0.5), got " + show(s.poisson_ratio));
    c.positive("density", s.density);
  } else {
    c.positive("mass", s.mass);
    c.non_negative("distance_compliance", s.distance_compliance);
    c.non_negative("volume_compliance", s.volume_compliance);
  }
  if (s.tets.empty()) c.at_least("neighbors", s.neighbors, 1);
  c.non_negative("damping", s.damping);
  c.positive("radius", s.radius);
  c.non_negative("friction", s.friction);
  if (s.thermal.enabled) {
    if (s.youngs_modulus == 0) c.fail("thermal", "needs the elastic material (youngs_modulus and tets): heat flows through the tets");
    c.positive("thermal.conductivity", s.thermal.conductivity);
    c.positive("thermal.specific_heat", s.thermal.specific_heat);
    c.positive("thermal.temperature", s.thermal.temperature);
    c.positive("thermal.frequency_factor", s.thermal.frequency_factor);
    c.positive("thermal.activation_energy", s.thermal.activation_energy);
    c.positive("thermal.damage_onset", s.thermal.damage_onset);
    c.positive("thermal.coagulated_stiffening", s.thermal.coagulated_stiffening);
    c.within("thermal.coagulated_shrinkage", s.thermal.coagulated_shrinkage, 0.0, 0.5);
  }
}

void fluid(const Fields& c, const Fluid& f) {
  c.points("positions", f.positions);
  c.positive("radius", f.radius);
  c.positive("rest_density", f.rest_density);
  c.non_negative("viscosity", f.viscosity);
  c.non_negative("cohesion", f.cohesion);
  c.non_negative("surface_tension", f.surface_tension);
  c.non_negative("vorticity", f.vorticity);
  c.non_negative("friction", f.friction);
  c.non_negative("damping", f.damping);
  if (f.emit_rate > 0) c.at_least("emit_width", f.emit_width, 1);
  c.finite("emit_origin", f.emit_origin);
  c.finite("emit_velocity", f.emit_velocity);
}

void strand(const Fields& c, const Strand& s) {
  c.points("points", s.points);
  if (s.points.size() < 6) c.fail("points", "needs at least 2 points");
  c.positive("mass", s.mass);
  c.positive("radius", s.radius);
  c.non_negative("stretch_compliance", s.stretch_compliance);
  c.non_negative("bend_compliance", s.bend_compliance);
  c.non_negative("twist_compliance", s.twist_compliance);
  c.finite("initial_twist", s.initial_twist);
  c.non_negative("damping", s.damping);
  c.non_negative("friction", s.friction);
  c.non_negative("youngs_modulus", s.youngs_modulus);
  c.within("poisson_ratio", s.poisson_ratio, 0, 0.4999);
  c.positive("density", s.density);
}

void tendons(const Fields& c, const Tendons& t) {
  if (!c.world().has<Strand>(c.entity())) c.fail("", "needs a Strand on the same entity (the backbone)");
  const size_t n = c.world().get<Strand>(c.entity()).points.size() / 3;
  if (t.disks.size() < 2) c.fail("disks", "needs at least 2 disks (the base and the tip), got " + std::to_string(t.disks.size()));
  for (size_t i = 0; i < t.disks.size(); ++i) {
    const std::string f = "disks[" + std::to_string(i) + "]";
    if (t.disks[i] >= n) c.fail(f, "names particle " + std::to_string(t.disks[i]) + " of the Strand's " + std::to_string(n));
    if (i > 0 && t.disks[i] <= t.disks[i - 1]) c.fail(f, "must be above the disk before it (disks go from base to tip)");
  }
  if (t.holes.empty() || t.holes.size() % 2) c.fail("holes", "needs x y per tendon, got " + std::to_string(t.holes.size()) + " numbers");
  for (size_t i = 0; i < t.holes.size(); ++i) c.finite("holes[" + std::to_string(i / 2) + "]", t.holes[i]);
  c.non_negative("stiffness", t.stiffness);
}

void needle(const Fields& c, const Needle& n) {
  if (!c.world().has<RigidBody>(c.entity())) c.fail("", "needs a RigidBody on the same entity (the needle is rigid)");
  c.positive("arc_radius", n.arc_radius);
  c.within("arc_angle", n.arc_angle, 1e-3, 2 * 3.14159265);
  c.finite("center", n.center);
  c.rotation("rotation", n.rotation);
  c.positive("puncture_force", n.puncture_force);
  c.positive("puncture_depth", n.puncture_depth);
  c.non_negative("friction", n.friction);
  c.non_negative("squeeze", n.squeeze);
  c.at_least("max_punctures", n.max_punctures, 2);
  if (n.max_punctures > 64)  // the taut thread's string is solved in one thread's registers
    c.fail("max_punctures", "is " + std::to_string(n.max_punctures) + "; at most 64 (particle_needle_solve.comp.hlsl, MAX_STRING)");
  if (n.thread >= 0) {
    const World& w = c.world();
    if (uint64_t(n.thread) >= w.entity_count() || !w.has<Strand>(EntityId(n.thread)))
      c.fail("thread", "names entity " + std::to_string(n.thread) + ", which has no Strand");
    if (w.get<Strand>(EntityId(n.thread)).points.size() / 3 > 256)
      c.fail("thread", "names a Strand of " + std::to_string(w.get<Strand>(EntityId(n.thread)).points.size() / 3) +
                           " particles; a needle's thread has at most 256 (particle_needle.hlsli, MAX_THREAD)");
    if (w.env_of(EntityId(n.thread)) != w.env_of(c.entity()))
      c.fail("thread", "names entity " + std::to_string(n.thread) + " of env " + std::to_string(w.env_of(EntityId(n.thread))) +
                           "; a needle's thread is in its env");
  }
}

template <class C>
void check(const World& w, EntityId e, void (*fields)(const Fields&, const C&)) {
  if (w.has<C>(e)) fields(Fields(w, e, component_name<C>()), w.get<C>(e));
}

// shared meshes: finite vertices (a NaN vertex poisons the culling bounds of every env)
void meshes(const World& w) {
  for (size_t m = 0; m < w.meshes().size(); ++m) {
    const Mesh& mesh = w.meshes()[m];
    for (const auto* v : {&mesh.positions, &mesh.normals, &mesh.uvs})
      for (float x : *v)
        if (!std::isfinite(x))
          throw std::invalid_argument("mesh " + std::to_string(m) + ": " +
                                      (v == &mesh.positions ? "positions" : v == &mesh.normals ? "normals" : "uvs") +
                                      " must be finite, got " + show(x));
  }
}

}  // namespace

void validate_transform(const World& w, EntityId e, const Transform& t) {
  transform(Fields(w, e, component_name<Transform>()), t);
}

void validate_world(const World& w) {
  meshes(w);
  for (EntityId e = 0; e < w.entity_count(); ++e) {
    check(w, e, transform);
    check(w, e, rigid_body);
    check(w, e, collider);
    check(w, e, joint);
    check(w, e, renderable);
    check(w, e, material);
    check(w, e, camera);
    check(w, e, light);
    check(w, e, environment_light);
    check(w, e, ultrasound_probe);
    check(w, e, ultrasound_tissue);
    check(w, e, soft_body);
    check(w, e, fluid);
    check(w, e, strand);
    check(w, e, tendons);
    check(w, e, needle);
  }
}

}  // namespace cressim::scene
