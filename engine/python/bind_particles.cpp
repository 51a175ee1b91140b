// Particle objects (SoftBody, Fluid, Strand), tet meshes, and the engine's particle layout
// mapping and attachments.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "physics/tet_mesh.h"
#include "python/bindings.h"
#include "python/entity.h"
#include "runtime/engine.h"

namespace py = pybind11;

namespace cressim::python {
namespace {

using FloatArray = py::array_t<float, py::array::c_style | py::array::forcecast>;
using IndexArray = py::array_t<int64_t, py::array::c_style | py::array::forcecast>;

// a 1-d array of non-negative indices; `what` names the argument in errors
std::vector<uint32_t> indices(const IndexArray& a, const char* what) {
  if (a.ndim() > 1) throw std::invalid_argument(std::string(what) + " must be a 1-d array of indices");
  std::vector<uint32_t> out(size_t(a.size()));
  const int64_t* d = a.data();
  for (size_t k = 0; k < out.size(); ++k) {
    if (d[k] < 0 || d[k] > int64_t(UINT32_MAX))
      throw std::out_of_range(std::string(what) + "[" + std::to_string(k) + "] = " + std::to_string(d[k]) +
                              " is not a valid index");
    out[k] = uint32_t(d[k]);
  }
  return out;
}

// an (n, 3) array of points as a flat list; `what` names the argument in errors
std::vector<float> points(py::handle o, const char* what) {
  auto a = FloatArray::ensure(o);
  if (!a || (a.size() && (a.ndim() != 2 || a.shape(1) != 3)))
    throw py::value_error(std::string(what) + ": give an (n, 3) array of points");
  return {a.data(), a.data() + a.size()};
}

// an (n, 2) array of offsets as a flat list
std::vector<float> points2(py::handle o, const char* what) {
  auto a = FloatArray::ensure(o);
  if (!a || a.ndim() != 2 || a.shape(1) != 2) throw py::value_error(std::string(what) + ": give an (n, 2) array of x y offsets");
  return {a.data(), a.data() + a.size()};
}

// an (n, k) array of indices as a flat list
std::vector<uint32_t> indices(py::handle o, size_t k, const char* what) {
  if (o.is_none()) return {};
  auto a = IndexArray::ensure(o);
  if (!a || (a.size() && k > 1 && (a.ndim() != 2 || size_t(a.shape(1)) != k)))
    throw py::value_error(std::string(what) + ": give an (n, " + std::to_string(k) + ") array of indices");
  std::vector<uint32_t> v;
  for (py::ssize_t i = 0; i < a.size(); ++i) {
    if (a.data()[i] < 0) throw py::value_error(std::string(what) + ": negative index");
    v.push_back(uint32_t(a.data()[i]));
  }
  return v;
}

template <class T>
py::array_t<T> array(const std::vector<T>& v, std::vector<py::ssize_t> shape) {
  py::array_t<T> a(shape);
  std::copy(v.begin(), v.end(), a.mutable_data());
  return a;
}

py::array_t<float> points_of(const std::vector<float>& v) { return array(v, {py::ssize_t(v.size() / 3), 3}); }

template <class C>
Entity add(Entity& e, const C& c) {
  e.world->add(e.id, c);
  return e;
}

}  // namespace

void bind_particles(py::module_& m) {
  using physics::TetMesh;
  py::class_<TetMesh>(m, "TetMesh", "A tetrahedral mesh for SoftBody: vertices, tets and its boundary triangles.")
      .def_static("box", &physics::tetrahedralize_box, py::arg("half_extents"), py::arg("cells"),
                  "A box centred at the origin, cells=(nx, ny, nz) cubes of 6 tets each.")
      .def_static("cylinder", &physics::tetrahedralize_cylinder, py::arg("radius"), py::arg("half_height"),
                  py::arg("cells_across") = 6, py::arg("cells_along") = 6, "A cylinder along z centred at the origin.")
      .def_static("load", &physics::load_msh, py::arg("path"), "Reads a Gmsh .msh file (ASCII 2.2 or 4.1).")
      .def_property_readonly("positions", [](const TetMesh& t) { return points_of(t.positions); })
      .def_property_readonly("tets", [](const TetMesh& t) { return array(t.tets, {py::ssize_t(t.tet_count()), 4}); })
      .def_property_readonly("triangles", [](const TetMesh& t) {
        return array(t.triangles, {py::ssize_t(t.triangles.size() / 3), 3});
      })
      .def("__repr__", [](const TetMesh& t) {
        return "<TetMesh " + std::to_string(t.vertex_count()) + " vertices, " + std::to_string(t.tet_count()) + " tets>";
      });

  py::class_<scene::Thermal>(m, "Thermal")
      .def(py::init([](float conductivity, float specific_heat, float temperature, double frequency_factor,
                       double activation_energy, float damage_onset, float coagulated_stiffening,
                       float coagulated_shrinkage) {
             scene::Thermal t;
             t.enabled = true;
             t.conductivity = conductivity, t.specific_heat = specific_heat, t.temperature = temperature;
             t.frequency_factor = frequency_factor, t.activation_energy = activation_energy;
             t.damage_onset = damage_onset;
             t.coagulated_stiffening = coagulated_stiffening, t.coagulated_shrinkage = coagulated_shrinkage;
             return t;
           }),
           py::kw_only(), py::arg("conductivity") = 0.52f, py::arg("specific_heat") = 3540.f,
           py::arg("temperature") = 310.15f, py::arg("frequency_factor") = 7.39e39, py::arg("activation_energy") = 2.577e5,
           py::arg("damage_onset") = 315.15f, py::arg("coagulated_stiffening") = 4.0f,
           py::arg("coagulated_shrinkage") = 0.1f,
           "Heat in an elastic SoftBody (docs/particles.md, \"Heat\"): conductivity (W/m/K), specific_heat "
           "(J/kg/K), the starting temperature (K), and the Arrhenius pair of its thermal damage: frequency_factor "
           "A (1/s) and activation_energy Ea (J/mol), the damage growing at A exp(-Ea / (R T)) per second above "
           "damage_onset (K, default 42 C). Coagulated tissue (its share 1 - exp(-Omega)) is coagulated_stiffening "
           "times stiffer and shrinks by coagulated_shrinkage (linear strain), and an energized tool cuts it. "
           "Defaults: liver at 37 C.")
      .def_readonly("conductivity", &scene::Thermal::conductivity)
      .def_readonly("specific_heat", &scene::Thermal::specific_heat)
      .def_readonly("temperature", &scene::Thermal::temperature)
      .def_readonly("frequency_factor", &scene::Thermal::frequency_factor)
      .def_readonly("activation_energy", &scene::Thermal::activation_energy)
      .def_readonly("damage_onset", &scene::Thermal::damage_onset)
      .def_readonly("coagulated_stiffening", &scene::Thermal::coagulated_stiffening)
      .def_readonly("coagulated_shrinkage", &scene::Thermal::coagulated_shrinkage);

  py::class_<scene::SoftBody>(m, "SoftBody")
      .def(py::init([](py::object shape, py::object tets, py::object triangles, py::object fixed, py::object youngs_modulus,
                       float poisson_ratio, float density, py::object mass, py::object distance_compliance,
                       py::object volume_compliance, uint32_t neighbors, float damping, float radius, float friction,
                       bool self_collision, py::object thermal) {
             scene::SoftBody s;
             if (py::isinstance<TetMesh>(shape)) {
               const auto& t = shape.cast<const TetMesh&>();
               s.positions = t.positions, s.tets = t.tets, s.triangles = t.triangles;
             } else {
               s.positions = points(shape, "SoftBody positions");
               s.tets = indices(tets, 4, "SoftBody tets");
               s.triangles = indices(triangles, 3, "SoftBody triangles");
             }
             s.fixed = indices(fixed, 1, "SoftBody fixed");
             // the expert (compliance) model: asked for by a compliance, and the only one without tets
             const bool compliance = !distance_compliance.is_none() || !volume_compliance.is_none() || s.tets.empty();
             if (compliance && !youngs_modulus.is_none())
               throw py::value_error(s.tets.empty()
                                         ? "SoftBody: youngs_modulus needs tets (a meshfree body is tied by distance "
                                           "constraints: give distance_compliance)"
                                         : "SoftBody: give either youngs_modulus (the material) or compliances (the "
                                           "expert XPBD model), not both");
             if (!compliance && !mass.is_none())
               throw py::value_error("SoftBody: an elastic body's mass comes from density x volume; give density "
                                     "(kg/m^3), or compliances for the per-particle mass model");
             if (compliance) {
               s.youngs_modulus = 0;
               if (!distance_compliance.is_none()) s.distance_compliance = distance_compliance.cast<float>();
               if (!volume_compliance.is_none()) s.volume_compliance = volume_compliance.cast<float>();
               if (!mass.is_none()) s.mass = mass.cast<float>();
             } else if (!youngs_modulus.is_none()) {
               s.youngs_modulus = youngs_modulus.cast<float>();
             }
             s.poisson_ratio = poisson_ratio, s.density = density;
             s.neighbors = neighbors, s.damping = damping, s.radius = radius, s.friction = friction;
             s.self_collision = self_collision;
             if (!thermal.is_none()) s.thermal = thermal.cast<scene::Thermal>();
             return s;
           }),
           py::arg("shape"), py::arg("tets") = py::none(), py::arg("triangles") = py::none(), py::kw_only(),
           py::arg("fixed") = py::none(), py::arg("youngs_modulus") = py::none(), py::arg("poisson_ratio") = 0.45f,
           py::arg("density") = 1000.f, py::arg("mass") = py::none(), py::arg("distance_compliance") = py::none(),
           py::arg("volume_compliance") = py::none(), py::arg("neighbors") = 8u, py::arg("damping") = 0.f,
           py::arg("radius") = 0.02f, py::arg("friction") = 0.5f, py::arg("self_collision") = false,
           py::arg("thermal") = py::none(),
           "A soft body: shape is a TetMesh, or an (n, 3) array of particle positions (entity frame) with tets "
           "(m, 4) and surface triangles (k, 3), or without tets a meshfree body tied to its `neighbors` nearest "
           "particles. fixed: particle indices clamped in place. A tet mesh is an elastic material: stable "
           "Neo-Hookean with youngs_modulus (Pa, default 10 kPa), poisson_ratio (default 0.45) and density (kg/m^3, "
           "default 1000; the mass is density x volume). Expert model (meshfree bodies, or when a compliance is "
           "given): XPBD compliances of the strain constraints |d|/L - 1 and V/V0 - 1 (defaults 1e-4) and a mass per "
           "particle (kg, default 0.01). thermal: a Thermal, for heat in an elastic body (none by default).")
      .def_property_readonly("particle_count", [](const scene::SoftBody& s) { return s.positions.size() / 3; })
      .def_property_readonly("positions", [](const scene::SoftBody& s) { return points_of(s.positions); })
      .def_readonly("mass", &scene::SoftBody::mass)
      .def_readonly("youngs_modulus", &scene::SoftBody::youngs_modulus)
      .def_readonly("poisson_ratio", &scene::SoftBody::poisson_ratio)
      .def_readonly("density", &scene::SoftBody::density)
      .def_readonly("radius", &scene::SoftBody::radius);

  py::class_<scene::Fluid>(m, "Fluid")
      .def(py::init([](py::object positions, uint32_t budget, float radius, float rest_density, float viscosity,
                       float cohesion, float surface_tension, float vorticity, float friction, float damping,
                       uint32_t emit_rate, uint32_t emit_width, scene::Vec3 emit_origin, scene::Vec3 emit_velocity) {
             scene::Fluid f;
             f.positions = points(positions, "Fluid positions");
             f.budget = budget, f.radius = radius, f.rest_density = rest_density, f.viscosity = viscosity;
             f.cohesion = cohesion, f.surface_tension = surface_tension, f.vorticity = vorticity;
             f.friction = friction, f.damping = damping;
             f.emit_rate = emit_rate, f.emit_width = emit_width, f.emit_origin = emit_origin;
             f.emit_velocity = emit_velocity;
             return f;
           }),
           py::arg("positions"), py::kw_only(), py::arg("budget") = 0u, py::arg("radius") = 0.05f,
           py::arg("rest_density") = 1000.f, py::arg("viscosity") = 0.01f, py::arg("cohesion") = 0.f,
           py::arg("surface_tension") = 0.f, py::arg("vorticity") = 0.f, py::arg("friction") = 0.1f,
           py::arg("damping") = 0.f, py::arg("emit_rate") = 0u, py::arg("emit_width") = 4u,
           py::arg("emit_origin") = scene::Vec3{0, 0, 0}, py::arg("emit_velocity") = scene::Vec3{0, 0, -1},
           "Position-based fluid: `positions` (n, 3) start active, `budget` slots in all (0: n), the rest "
           "inactive until emitted: each frame up to `emit_rate` slots start on a square nozzle of "
           "`emit_width` x `emit_width` lattice points at `emit_origin` (entity frame), moving at "
           "`emit_velocity`. Rest spacing 2 x radius, kernel support 4 x radius.")
      .def_readonly("radius", &scene::Fluid::radius)
      .def_readonly("rest_density", &scene::Fluid::rest_density)
      .def_readonly("budget", &scene::Fluid::budget);

  py::class_<scene::Strand>(m, "Strand")
      .def(py::init([](py::object pts, py::object fixed, py::object mass, float radius, float stretch, py::object bend,
                       py::object twist, float initial_twist, float damping, float friction, bool self_collision,
                       py::object youngs_modulus, float poisson_ratio, float density, bool soft_body_contacts) {
             scene::Strand s;
             s.points = points(pts, "Strand points");
             s.fixed = indices(fixed, 1, "Strand fixed");
             if (!youngs_modulus.is_none()) {
               if (!mass.is_none() || !bend.is_none() || !twist.is_none())
                 throw py::value_error("Strand: give either youngs_modulus (a rod of a material: its density gives "
                                       "the mass, E and poisson_ratio the bending and twist) or mass and "
                                       "compliances, not both");
               s.youngs_modulus = youngs_modulus.cast<float>();
               if (!(s.youngs_modulus > 0)) throw py::value_error("Strand.youngs_modulus must be positive");
             }
             if (!mass.is_none()) s.mass = mass.cast<float>();
             if (!bend.is_none()) s.bend_compliance = bend.cast<float>();
             if (!twist.is_none()) s.twist_compliance = twist.cast<float>();
             s.radius = radius, s.stretch_compliance = stretch, s.initial_twist = initial_twist;
             s.damping = damping, s.friction = friction, s.self_collision = self_collision;
             s.poisson_ratio = poisson_ratio, s.density = density, s.soft_body_contacts = soft_body_contacts;
             return s;
           }),
           py::arg("points"), py::kw_only(), py::arg("fixed") = py::none(), py::arg("mass") = py::none(),
           py::arg("radius") = 0.005f, py::arg("stretch_compliance") = 0.f, py::arg("bend_compliance") = py::none(),
           py::arg("twist_compliance") = py::none(), py::arg("initial_twist") = 0.f, py::arg("damping") = 0.f,
           py::arg("friction") = 0.3f, py::arg("self_collision") = false, py::arg("youngs_modulus") = py::none(),
           py::arg("poisson_ratio") = 0.3f, py::arg("density") = 1000.f, py::arg("soft_body_contacts") = true,
           "A thread or cable through `points` (n, 3), a Cosserat rod: segment distance, stretch-shear, bend "
           "and twist constraints (rest straight and untwisted; initial_twist radians spread along it); "
           "self-collision off unless asked. Either a thread of given mass per particle (default 1 g) and XPBD "
           "compliances (bend and twist default 1e-3), or a rod of a material: youngs_modulus (Pa), "
           "poisson_ratio and density (kg/m^3) with a solid round section of `radius`. soft_body_contacts=False: "
           "it passes through soft bodies (a suture thread sewn into tissue by a cressim.Needle).")
      .def_readonly("mass", &scene::Strand::mass)
      .def_readonly("youngs_modulus", &scene::Strand::youngs_modulus);

  py::class_<scene::Tendons>(m, "Tendons")
      .def(py::init([](py::object disks, py::object holes, float stiffness) {
             scene::Tendons t;
             t.disks = indices(disks, 1, "Tendons disks");
             t.holes = points2(holes, "Tendons holes");
             t.stiffness = stiffness;
             return t;
           }),
           py::arg("disks"), py::arg("holes"), py::kw_only(), py::arg("stiffness") = 0.f,
           "Tendons routed along the Strand on the same entity (a cable-driven continuum robot): spacer disks "
           "at the strand particles `disks` (base first, tip last), each turning with the segment frame that "
           "starts there, and one tendon per row of `holes` (k, 2): its hole in every disk (x, y in the "
           "disk's frame, m; z runs along the strand). A tendon ends at the last disk and slides through "
           "the others; control.tendon_commands drives it (mode, value): 0 slack, 1 pulled in by a "
           "displacement (m; the default, 0, holds it at its rest length), 2 pulled with a tension (N). "
           "stiffness: each tendon's axial EA (N; 0 inextensible).")
      .def_readonly("disks", &scene::Tendons::disks)
      .def_readonly("holes", &scene::Tendons::holes);

  py::class_<scene::Needle>(m, "Needle")
      .def(py::init([](py::object thread, float arc_radius, float arc_angle, scene::Vec3 center, scene::Quat rotation,
                       float puncture_force, float puncture_depth, float friction, float squeeze,
                       uint32_t max_punctures) {
             scene::Needle n;
             if (!thread.is_none()) n.thread = py::isinstance<Entity>(thread) ? int64_t(thread.cast<Entity>().id)
                                                                               : thread.cast<int64_t>();
             n.arc_radius = arc_radius, n.arc_angle = arc_angle, n.center = center, n.rotation = rotation;
             n.puncture_force = puncture_force, n.puncture_depth = puncture_depth, n.friction = friction;
             n.squeeze = squeeze, n.max_punctures = max_punctures;
             return n;
           }),
           py::kw_only(), py::arg("thread") = py::none(), py::arg("arc_radius") = 0.008f,
           py::arg("arc_angle") = 2.35619449f, py::arg("center") = scene::Vec3{0, 0, 0},
           py::arg("rotation") = scene::Quat{0, 0, 0, 1}, py::arg("puncture_force") = 1.0f,
           py::arg("puncture_depth") = 0.002f, py::arg("friction") = 0.3f,
           py::arg("squeeze") = 0.0f, py::arg("max_punctures") = 8u,
           "A curved suture needle on the entity's rigid body: a circular arc of `arc_radius` (m) in the xy plane "
           "of the arc frame (`center`, `rotation` in the body frame) about its z axis, from the tail at angle 0 "
           "to the tip at `arc_angle` (rad, counter-clockwise). `thread`: a Strand entity of the same env whose "
           "first particle is tied to the tail. Where the tip meets a soft body's surface it pushes it until "
           "the surface takes `puncture_force` (N) or the tip is `puncture_depth` (m) past where it met it, then "
           "passes through; the punctured points slide along the "
           "needle against Coulomb `friction`, then the thread slides through them freely, and they stop at the "
           "thread's last particle (a knot). `squeeze` > 0 (N, the tissue's grip on the thread) switches on "
           "friction on the thread: a puncture holds it up to T_high <= T_low exp(friction * turn) + friction * "
           "squeeze (docs/particles.md). `max_punctures` records (entries and exits).")
      .def_readonly("arc_radius", &scene::Needle::arc_radius)
      .def_readonly("arc_angle", &scene::Needle::arc_angle)
      .def_readonly("thread", &scene::Needle::thread);

  auto entity = py::reinterpret_borrow<py::class_<Entity>>(m.attr("Entity"));
  py::class_<scene::Material>(m, "Material")
      .def(py::init([](std::array<float, 4> color, float metallic, float roughness, uint32_t seg) {
             return scene::Material{color, metallic, roughness, seg};
           }),
           py::kw_only(), py::arg("color") = std::array<float, 4>{0.8f, 0.8f, 0.8f, 1.0f}, py::arg("metallic") = 0.f,
           py::arg("roughness") = 0.5f, py::arg("segmentation_id") = 0u,
           "The look of the SoftBody, Strand or Fluid on the same entity (drawn from the physics buffers). "
           "color: linear base colour (a fluid's: what 2 cm of it shows over white); segmentation_id 0: "
           "entity id + 1.")
      .def_readwrite("color", &scene::Material::color)
      .def_readwrite("metallic", &scene::Material::metallic)
      .def_readwrite("roughness", &scene::Material::roughness)
      .def_readwrite("segmentation_id", &scene::Material::segmentation_id);

  entity.def("add", &add<scene::Material>, py::arg("component"))
      .def("add", &add<scene::SoftBody>, py::arg("component"))
      .def("add", &add<scene::Fluid>, py::arg("component"))
      .def("add", &add<scene::Strand>, py::arg("component"))
      .def("add", &add<scene::Tendons>, py::arg("component"))
      .def("add", &add<scene::Needle>, py::arg("component"));

  auto engine = py::reinterpret_borrow<py::class_<runtime::Engine>>(m.attr("Engine"));
  engine
      .def_property_readonly("particle_mapping", [](const runtime::Engine& e) {
        e.mapping();  // prepared?
        py::dict d;
        const physics::ParticleSystem* ps = e.particles();
        physics::ParticleModel empty;
        const auto& pm = ps ? ps->model() : empty;
        std::vector<uint32_t> entity = pm.object_entity, env, kind, offset, count, budget, env_offset, env_count;
        for (auto& o : pm.objects) {
          offset.push_back(o.range.x), count.push_back(o.range.y), env.push_back(o.range.z), kind.push_back(o.range.w);
          budget.push_back(o.ids.z);
        }
        for (auto& r : pm.env_ranges) env_offset.push_back(r.range.x), env_count.push_back(r.range.y);
        auto v = [](const std::vector<uint32_t>& x) { return array(x, {py::ssize_t(x.size())}); };
        d["object_entity"] = v(entity);
        d["object_env"] = v(env);
        d["object_kind"] = v(kind);
        d["object_offset"] = v(offset);
        d["object_count"] = v(count);
        d["env_offset"] = v(env_offset);
        d["env_count"] = v(env_count);
        d["surface"] = array(pm.surface, {py::ssize_t(pm.surface.size() / 3), 3});
        d["surface_offset"] = v(pm.surface_offset);
        d["surface_count"] = v(pm.surface_count);
        py::dict sets;
        for (auto& s : pm.sets) {
          py::dict r;
          r["colour_offset"] = v(s.colour_offset);
          r["colour_count"] = v(s.colour_count);
          r["object_count"] = v(s.object_count);
          r["multipliers"] = s.multipliers;
          r["chains"] = array(s.chains, {py::ssize_t(s.chains.size() / 2), 2});
          if (s.rows_per_record) {  // vertex-solved: the particles' colours (particles.<name>_vertices)
            r["vertex_colour_offset"] = v(s.vertex_colour_offset);
            r["vertex_colour_count"] = v(s.vertex_colour_count);
          }
          sets[py::str(s.name)] = r;
        }
        d["constraints"] = sets;
        d["kinds"] = py::dict(py::arg("solid") = shader::PARTICLE_SOLID, py::arg("fluid") = shader::PARTICLE_FLUID,
                              py::arg("strand") = shader::PARTICLE_STRAND);
        return d;
      },
      "Particle objects (entity, env, kind, first particle, count), each env's particle range, the surface "
      "triangles (global particle indices, each object's slice), and each constraint set's colour ranges of "
      "particles.<name>_constraints rows (a row's object is its first particle's), constraints per object, XPBD "
      "multipliers per row and, for a family solved along chains (bend_twist, stretch), each chain's (first row, count).")
      .def("attach_particle",
           [](runtime::Engine& e, uint32_t env, uint32_t slot, uint32_t particle, py::object body, float compliance,
              bool hold_frame, std::optional<std::array<float, 4>> frame_offset) {
             const uint32_t id = py::isinstance<Entity>(body) ? body.cast<Entity>().id : body.cast<uint32_t>();
             e.attach_particle(env, slot, particle, id, compliance, hold_frame, frame_offset);
           },
           py::arg("env"), py::arg("slot"), py::arg("particle"),
           py::arg("body"), py::arg("compliance") = 0.f, py::arg("hold_frame") = false,
           py::arg("frame_offset") = py::none(),
           "Ties particle (global index) to the rigid body of entity `body` where both are at the next step, in "
           "attachment slot `slot` of `env` (no reallocation). hold_frame (a strand's particle): the segment "
           "at that particle also keeps its material frame at body rotation * frame_offset (xyzw; default: "
           "the offset at the next step), so turning the body twists the strand.")
      .def("release_particle", &runtime::Engine::release_particle, py::arg("env"), py::arg("slot"))
      .def("remove_particles",
           [](runtime::Engine& e, IndexArray particles) { e.remove_particles(indices(particles, "particles")); },
           py::arg("particles"),
           "Fluid particles (global indices, any envs) become inactive slots at the next step: "
           "particles.emitted drops and emitters reuse the slots. Task passes write control.particle_remove.")
      .def("cut_constraints",
           [](runtime::Engine& e, const std::string& family, IndexArray rows, bool cut) {
             e.cut_constraints(family, indices(rows, "indices"), cut);
           },
           py::arg("family"), py::arg("indices"), py::arg("cut") = true,
           "Switches constraints (rows of particles.<family>_constraints) off from the next step (cut=False: "
           "on again); an env reset restores its constraints. Task passes write control.particle_<family>_cut.");
}

}  // namespace cressim::python
