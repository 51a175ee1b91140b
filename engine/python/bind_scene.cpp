#include <cstring>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "python/bindings.h"
#include "python/entity.h"
#include "render/primitives.h"
#include "scene/world.h"

namespace py = pybind11;

namespace cressim::python {
namespace {

template <class C>
Entity add(Entity& e, const C& c) {
  e.world->add(e.id, c);
  return e;
}

template <class E>
E parse_enum(const std::string& name, std::initializer_list<std::pair<const char*, E>> values, const char* what) {
  std::string valid;
  for (auto& [n, v] : values) {
    if (name == n) return v;
    valid += std::string(valid.empty() ? "" : ", ") + n;
  }
  throw py::value_error(std::string(what) + " '" + name + "' is not one of: " + valid);
}

int64_t entity_id(py::object o) {
  if (o.is_none()) return -1;
  if (py::isinstance<Entity>(o)) return int64_t(o.cast<Entity>().id);
  return o.cast<int64_t>();
}

const char* shape_name(scene::ShapeKind k) {
  switch (k) {
    case scene::ShapeKind::SPHERE: return "sphere";
    case scene::ShapeKind::BOX: return "box";
    case scene::ShapeKind::CAPSULE: return "capsule";
    case scene::ShapeKind::PLANE: return "plane";
    default: return "none";
  }
}

const char* joint_name(scene::JointKind k) {
  switch (k) {
    case scene::JointKind::FIXED: return "fixed";
    case scene::JointKind::BALL: return "ball";
    case scene::JointKind::SPHERICAL: return "spherical";
    case scene::JointKind::HINGE: return "hinge";
    case scene::JointKind::SLIDER: return "slider";
    default: return "none";
  }
}

void bind_physics_components(py::module_& m) {
  using scene::Quat;
  using scene::Vec3;
  py::class_<scene::RigidBody>(m, "RigidBody")
      .def(py::init([](float mass, float density, Vec3 inertia, bool kinematic, float ld, float ad) {
             return scene::RigidBody{mass, density, inertia, kinematic, ld, ad};
           }),
           py::kw_only(), py::arg("mass") = 0.f, py::arg("density") = 1000.f, py::arg("inertia") = Vec3{0, 0, 0},
           py::arg("kinematic") = false, py::arg("linear_damping") = 0.f, py::arg("angular_damping") = 0.f,
           "A rigid body at the entity origin. mass 0: density x collider volume; inertia 0: from the shapes.")
      .def_readwrite("mass", &scene::RigidBody::mass)
      .def_readwrite("density", &scene::RigidBody::density)
      .def_readwrite("inertia", &scene::RigidBody::inertia)
      .def_readwrite("kinematic", &scene::RigidBody::kinematic)
      .def_readwrite("linear_damping", &scene::RigidBody::linear_damping)
      .def_readwrite("angular_damping", &scene::RigidBody::angular_damping);

  auto shape = [](scene::ShapeKind k, Vec3 size, Vec3 p, Quat q) { return scene::Shape{k, size, p, q}; };
  py::class_<scene::Shape>(m, "Shape")
      .def_static("sphere", [=](float r, Vec3 p, Quat q) { return shape(scene::ShapeKind::SPHERE, {r, 0, 0}, p, q); },
                  py::arg("radius"), py::kw_only(), py::arg("position") = Vec3{0, 0, 0},
                  py::arg("rotation") = Quat{0, 0, 0, 1})
      .def_static("box", [=](Vec3 he, Vec3 p, Quat q) { return shape(scene::ShapeKind::BOX, he, p, q); },
                  py::arg("half_extents"), py::kw_only(), py::arg("position") = Vec3{0, 0, 0},
                  py::arg("rotation") = Quat{0, 0, 0, 1})
      .def_static("capsule",
                  [=](float r, float hh, Vec3 p, Quat q) { return shape(scene::ShapeKind::CAPSULE, {r, hh, 0}, p, q); },
                  py::arg("radius"), py::arg("half_height"), py::kw_only(), py::arg("position") = Vec3{0, 0, 0},
                  py::arg("rotation") = Quat{0, 0, 0, 1}, "A capsule along the shape's z axis.")
      .def_static("plane", [=](Vec3 p, Quat q) { return shape(scene::ShapeKind::PLANE, {0, 0, 0}, p, q); },
                  py::kw_only(), py::arg("position") = Vec3{0, 0, 0}, py::arg("rotation") = Quat{0, 0, 0, 1},
                  "An infinite plane through the shape origin with normal +z (static entities only).")
      .def_static("proxy_particles",
                  [=](std::vector<Vec3> points, float r) {
                    std::vector<scene::Shape> out;
                    for (auto& p : points) out.push_back(shape(scene::ShapeKind::SPHERE, {r, 0, 0}, p, {0, 0, 0, 1}));
                    return out;
                  },
                  py::arg("points"), py::arg("radius"), "Spheres at body-frame points: a proxy-particle collider.")
      .def_property_readonly("kind", [](const scene::Shape& s) { return shape_name(s.kind); })
      .def_readonly("size", &scene::Shape::size)
      .def_readonly("position", &scene::Shape::position)
      .def_readonly("rotation", &scene::Shape::rotation)
      .def("__repr__", [](const scene::Shape& s) { return std::string("<Shape ") + shape_name(s.kind) + ">"; });

  py::class_<scene::Collider>(m, "Collider")
      .def(py::init([](py::object shapes, float sf, py::object df, float restitution, uint32_t group, uint32_t mask) {
             scene::Collider c;
             if (py::isinstance<scene::Shape>(shapes)) c.shapes.push_back(shapes.cast<scene::Shape>());
             else c.shapes = shapes.cast<std::vector<scene::Shape>>();
             c.static_friction = sf;
             c.dynamic_friction = df.is_none() ? sf : df.cast<float>();
             c.restitution = restitution;
             c.group = group;
             c.mask = mask;
             return c;
           }),
           py::arg("shapes"), py::kw_only(), py::arg("static_friction") = 0.5f, py::arg("dynamic_friction") = py::none(),
           py::arg("restitution") = 0.f, py::arg("group") = 1u, py::arg("mask") = 0xffffffffu)
      .def_readwrite("shapes", &scene::Collider::shapes)
      .def_readwrite("static_friction", &scene::Collider::static_friction)
      .def_readwrite("dynamic_friction", &scene::Collider::dynamic_friction)
      .def_readwrite("restitution", &scene::Collider::restitution)
      .def_readwrite("group", &scene::Collider::group)
      .def_readwrite("mask", &scene::Collider::mask);

  py::class_<scene::Joint>(m, "Joint")
      .def(py::init([](const std::string& kind, py::object a, py::object b, Vec3 anchor, Vec3 axis, py::object limits,
                       py::object drive, float target, Quat target_rotation, float stiffness, float damping,
                       float max_force, float compliance, bool collide_connected) {
             using scene::JointKind;
             scene::Joint j;
             j.kind = parse_enum<JointKind>(kind, {{"fixed", JointKind::FIXED}, {"ball", JointKind::BALL},
                                                  {"spherical", JointKind::SPHERICAL}, {"hinge", JointKind::HINGE},
                                                  {"slider", JointKind::SLIDER}}, "Joint kind");
             j.body_a = entity_id(a);
             j.body_b = entity_id(b);
             j.anchor = anchor;
             j.axis = axis;
             if (!limits.is_none()) {
               auto l = limits.cast<std::array<float, 2>>();
               j.limited = true, j.lower = l[0], j.upper = l[1];
             }
             if (!drive.is_none())
               j.drive = parse_enum<scene::DriveMode>(py::str(drive), {{"position", scene::DriveMode::POSITION},
                                                                      {"velocity", scene::DriveMode::VELOCITY}},
                                                      "Joint drive");
             j.target = target;
             j.target_rotation = target_rotation;
             j.stiffness = stiffness;
             j.damping = damping;
             j.max_force = max_force;
             j.compliance = compliance;
             j.collide_connected = collide_connected;
             return j;
           }),
           py::arg("kind"), py::kw_only(), py::arg("body_a") = py::none(), py::arg("body_b") = py::none(),
           py::arg("anchor") = Vec3{0, 0, 0}, py::arg("axis") = Vec3{1, 0, 0}, py::arg("limits") = py::none(),
           py::arg("drive") = py::none(), py::arg("target") = 0.f, py::arg("target_rotation") = Quat{0, 0, 0, 1},
           py::arg("stiffness") = 0.f, py::arg("damping") = 0.f,
           py::arg("max_force") = std::numeric_limits<float>::infinity(), py::arg("compliance") = 0.f,
           py::arg("collide_connected") = false,
           "A joint between two rigid bodies of one env (body_a None: the world). anchor and axis are world "
           "coordinates at the authored poses, where the joint coordinate is 0.")
      .def_property_readonly("kind", [](const scene::Joint& j) { return joint_name(j.kind); })
      .def_readonly("body_a", &scene::Joint::body_a)
      .def_readonly("body_b", &scene::Joint::body_b)
      .def_readonly("anchor", &scene::Joint::anchor)
      .def_readonly("axis", &scene::Joint::axis)
      .def_property_readonly("limits", [](const scene::Joint& j) -> py::object {
        return j.limited ? py::make_tuple(j.lower, j.upper) : py::object(py::none());
      });
}

void bind_render_components(py::module_& m) {
  using scene::Vec3;
  py::class_<scene::Mesh>(m, "Mesh", "A triangle mesh for Renderable.mesh (add it with world.add_mesh).")
      .def(py::init([](py::array_t<float, py::array::c_style | py::array::forcecast> positions,
                       py::array_t<uint32_t, py::array::c_style | py::array::forcecast> triangles,
                       py::array_t<float, py::array::c_style | py::array::forcecast> normals, py::object uvs,
                       std::string positions_key) {
             scene::Mesh mesh;
             mesh.positions.assign(positions.data(), positions.data() + positions.size());
             mesh.indices.assign(triangles.data(), triangles.data() + triangles.size());
             mesh.normals.assign(normals.data(), normals.data() + normals.size());
             if (!uvs.is_none()) {
               auto a = uvs.cast<py::array_t<float, py::array::c_style | py::array::forcecast>>();
               mesh.uvs.assign(a.data(), a.data() + a.size());
             }
             mesh.positions_key = std::move(positions_key);
             return mesh;
           }),
           py::arg("positions"), py::arg("triangles"), py::arg("normals"), py::arg("uvs") = py::none(),
           py::kw_only(), py::arg("positions_key") = "",
           "positions (V, 3), triangles (T, 3) vertex indices, normals (V, 3), optional uvs (V, 2) texture "
           "coordinates (v down the image); cressim.io.load_mesh reads .obj/.stl/.glb files. positions_key: an "
           "engine buffer of float4 rows (one per vertex) that the positions are copied from on the GPU every "
           "frame, e.g. a particle surface (normals then come from the triangles).")
      .def_static("box", &render::box_mesh, py::arg("half_extents"))
      .def_static("sphere", &render::sphere_mesh, py::arg("radius"), py::arg("rings") = 24, py::arg("segments") = 48)
      .def_static("capsule", &render::capsule_mesh, py::arg("radius"), py::arg("half_height"), py::arg("rings") = 12,
                  py::arg("segments") = 32)
      .def_static("plane", &render::plane_mesh, py::arg("half_size"))
      .def_property_readonly("vertex_count", &scene::Mesh::vertex_count)
      .def_property_readonly("has_uvs", [](const scene::Mesh& m) { return !m.uvs.empty(); })
      .def_readonly("positions_key", &scene::Mesh::positions_key)
      .def_property_readonly("triangle_count", [](const scene::Mesh& m) { return m.indices.size() / 3; });

  py::class_<scene::Texture>(m, "Texture", "An RGBA8 image for Renderable.texture (add it with world.add_texture).")
      .def(py::init([](py::array_t<uint8_t, py::array::c_style | py::array::forcecast> image) {
             if (image.ndim() != 3 || (image.shape(2) != 3 && image.shape(2) != 4))
               throw py::value_error("Texture: the image must be (height, width, 3 or 4) uint8");
             scene::Texture t{uint32_t(image.shape(1)), uint32_t(image.shape(0)), {}};
             const size_t texels = size_t(t.width) * t.height, channels = size_t(image.shape(2));
             t.rgba.resize(texels * 4, 255);
             for (size_t i = 0; i < texels; ++i)
               for (size_t k = 0; k < channels; ++k) t.rgba[4 * i + k] = image.data()[channels * i + k];
             return t;
           }),
           py::arg("image"), "image: (height, width, 3 or 4) uint8, sRGB, rows top to bottom; it wraps.")
      .def_readonly("width", &scene::Texture::width)
      .def_readonly("height", &scene::Texture::height)
      .def_property_readonly(
          "image",
          [](const scene::Texture& t) {
            py::array_t<uint8_t> a({size_t(t.height), size_t(t.width), size_t(4)});
            std::memcpy(a.mutable_data(), t.rgba.data(), t.rgba.size());
            return a;
          },
          "A copy of the texels: (height, width, 4) uint8.");

  py::class_<scene::Renderable>(m, "Renderable")
      .def(py::init([](uint32_t mesh, std::array<float, 4> color, float metallic, float roughness, uint32_t seg,
                       int32_t texture, int32_t normal_map, float normal_scale) {
             return scene::Renderable{mesh, color, metallic, roughness, seg, texture, normal_map, normal_scale};
           }),
           py::arg("mesh"), py::kw_only(), py::arg("color") = std::array<float, 4>{0.8f, 0.8f, 0.8f, 1.0f},
           py::arg("metallic") = 0.f, py::arg("roughness") = 0.5f, py::arg("segmentation_id") = 0u,
           py::arg("texture") = -1, py::arg("normal_map") = -1, py::arg("normal_scale") = 1.f,
           "Drawn by its env's cameras; segmentation_id 0: entity id + 1 (0 is the background). color: linear "
           "base colour; metallic/roughness: GGX material; texture: a world.add_texture index (-1: none); "
           "normal_map: a texture of tangent-space normals (RGB = xyz / 2 + 0.5, green toward the image's top, "
           "read as linear values), normal_scale scaling their x and y.")
      .def_readwrite("mesh", &scene::Renderable::mesh)
      .def_readwrite("color", &scene::Renderable::color)
      .def_readwrite("metallic", &scene::Renderable::metallic)
      .def_readwrite("roughness", &scene::Renderable::roughness)
      .def_readwrite("texture", &scene::Renderable::texture)
      .def_readwrite("normal_map", &scene::Renderable::normal_map)
      .def_readwrite("normal_scale", &scene::Renderable::normal_scale)
      .def_readwrite("segmentation_id", &scene::Renderable::segmentation_id);

  py::class_<scene::Camera>(m, "Camera")
      .def(py::init([](uint32_t w, uint32_t h, float fov_y, float fx, float fy, float cx, float cy, float near, float far,
                       std::vector<std::string> products) {
             scene::Camera c{w, h, fov_y, fx, fy, cx, cy, near, far, 0};
             for (const auto& p : products)
               c.products |= parse_enum<uint32_t>(p, {{"rgb", scene::PRODUCT_RGB}, {"depth", scene::PRODUCT_DEPTH},
                                                      {"segmentation", scene::PRODUCT_SEGMENTATION}}, "Camera product");
             if (!c.products) throw py::value_error("Camera: products needs at least one of rgb, depth, segmentation");
             return c;
           }),
           py::kw_only(), py::arg("width") = 64u, py::arg("height") = 64u, py::arg("fov_y") = 50.f, py::arg("fx") = 0.f,
           py::arg("fy") = 0.f, py::arg("cx") = -1.f, py::arg("cy") = -1.f, py::arg("near") = 0.01f,
           py::arg("far") = 100.f,
           py::arg("products") = std::vector<std::string>{"rgb", "depth", "segmentation"},
           "A pinhole camera looking along the entity's +z (x right, y down). fx/fy 0: from fov_y in degrees; "
           "cx/cy < 0: the image centre. products: the buffers it writes (camera{g}.rgb, .depth, .segmentation); "
           "fewer is less memory and bandwidth.")
      .def_readonly("width", &scene::Camera::width)
      .def_readonly("height", &scene::Camera::height)
      .def_property_readonly("products", [](const scene::Camera& c) {
        std::vector<std::string> out;
        if (c.products & scene::PRODUCT_RGB) out.push_back("rgb");
        if (c.products & scene::PRODUCT_DEPTH) out.push_back("depth");
        if (c.products & scene::PRODUCT_SEGMENTATION) out.push_back("segmentation");
        return out;
      });

  py::class_<scene::Light>(m, "Light")
      .def(py::init([](Vec3 color, float intensity, float ambient, const std::string& kind, float range, float inner,
                       float outer, bool shadows, float shadow_extent, uint32_t shadow_resolution) {
             using scene::LightKind;
             scene::Light l{color, intensity, ambient};
             l.kind = parse_enum<LightKind>(kind, {{"directional", LightKind::DIRECTIONAL}, {"point", LightKind::POINT},
                                                  {"spot", LightKind::SPOT}}, "Light kind");
             l.range = range, l.inner_angle = inner, l.outer_angle = outer;
             l.shadows = shadows, l.shadow_extent = shadow_extent, l.shadow_resolution = shadow_resolution;
             return l;
           }),
           py::kw_only(), py::arg("color") = Vec3{1, 1, 1}, py::arg("intensity") = 1.f, py::arg("ambient") = 0.2f,
           py::arg("kind") = "directional", py::arg("range") = 0.f, py::arg("inner_angle") = 20.f,
           py::arg("outer_angle") = 30.f, py::arg("shadows") = false, py::arg("shadow_extent") = 2.f,
           py::arg("shadow_resolution") = 256u,
           "A light at the entity's pose: 'directional' travels along the entity's +z, 'spot' points along it, "
           "'point' and 'spot' sit at its origin (radiance falls as 1/d^2, to 0 at `range` when > 0; spot cone "
           "half-angles in degrees). A white matte surface facing a light of intensity 1 (at 1 m) shows `color`. "
           "The env's first directional light with shadows=True casts shadows over a square of half-size "
           "shadow_extent (m) around the light entity. ambient: the env's uniform ambient (its first light's) "
           "when it has no EnvironmentLight.")
      .def_property_readonly("kind", [](const scene::Light& l) {
        return l.kind == scene::LightKind::POINT ? "point" : l.kind == scene::LightKind::SPOT ? "spot" : "directional";
      })
      .def_readonly("color", &scene::Light::color)
      .def_readonly("intensity", &scene::Light::intensity)
      .def_readonly("shadows", &scene::Light::shadows);

  py::class_<scene::EnvironmentLight>(m, "EnvironmentLight")
      .def(py::init([](Vec3 sky, Vec3 ground, float intensity, int32_t map) {
             return scene::EnvironmentLight{sky, ground, intensity, map};
           }),
           py::kw_only(), py::arg("sky") = Vec3{0.2f, 0.2f, 0.2f}, py::arg("ground") = Vec3{0.2f, 0.2f, 0.2f},
           py::arg("intensity") = 1.f, py::arg("map") = -1,
           "The env's ambient light (one per env): a hemisphere, `sky` from +z and `ground` from -z; or, with "
           "map (a world.add_texture index of an equirectangular image: rows from +z at the top to -z, columns "
           "from azimuth -180 deg to 180 deg, +x in the middle; sRGB texels), image-based lighting: radiance = "
           "the map's linear texels x intensity, filtered on the GPU (diffuse and specular).")
      .def_readonly("sky", &scene::EnvironmentLight::sky)
      .def_readonly("ground", &scene::EnvironmentLight::ground)
      .def_readonly("intensity", &scene::EnvironmentLight::intensity)
      .def_readonly("map", &scene::EnvironmentLight::map);
}

// keyword-only construction of a component with many fields: each keyword sets the field of
// that name through its property, so a misspelt keyword is an error naming the valid ones
template <class C>
std::unique_ptr<C> from_keywords(const char* type, const py::kwargs& kw) {
  auto c = std::make_unique<C>();
  py::object self = py::cast(c.get(), py::return_value_policy::reference);
  for (auto [key, value] : kw) {
    const std::string k = py::str(key);
    if (k.rfind("_", 0) == 0 || !py::hasattr(py::type::of(self), k.c_str())) {
      std::string valid;
      for (auto name : py::module_::import("builtins").attr("dir")(py::type::of(self)))
        if (std::string n = py::str(name); n.rfind("_", 0) != 0) valid += (valid.empty() ? "" : ", ") + n;
      throw py::type_error(std::string(type) + "() has no field '" + k + "'; fields: " + valid);
    }
    self.attr(k.c_str()) = value;
  }
  return c;
}

void bind_sensor_components(py::module_& m) {
  using scene::ProbeKind;
  using scene::RegionKind;
  using P = scene::UltrasoundProbe;
  py::class_<P>(m, "UltrasoundProbe",
                "An ultrasound probe (COLE B-mode) on the entity's face, looking along +z with its scanlines "
                "spread along x. Keyword fields (lengths in scene units): kind ('linear' or 'sector'), scanlines, "
                "line_length, line_spacing (linear), sector_angle (degrees) and radius (sector; 0: phased "
                "array), width, height, sampling_frequency (Hz), radial_decimation, center_frequency (Hz), "
                "fractional_bandwidth, lateral_beam_width and elevational_beam_width (FWHM), speed_of_sound "
                "(m/s), metres_per_unit, dynamic_range and gain (dB), time_gain_compensation (dB/cm of depth), "
                "focal_depth (the beam widths hold there and grow away from it as a Gaussian beam's; 0: constant "
                "widths), coupling_impedance (MRayl, outside every tissue), specular_amplitude (the echo of a "
                "perfect plane reflector in scatterer amplitudes), rf_output (also fill ultrasound0.rf). Defaults: "
                "an abdominal curvilinear probe.")
      .def(py::init([](py::kwargs kw) { return from_keywords<P>("UltrasoundProbe", kw); }))
      .def_property("kind",
                    [](const P& p) { return p.kind == ProbeKind::LINEAR ? "linear" : "sector"; },
                    [](P& p, const std::string& k) {
                      p.kind = parse_enum<ProbeKind>(k, {{"linear", ProbeKind::LINEAR}, {"sector", ProbeKind::SECTOR}},
                                                     "UltrasoundProbe kind");
                    })
      .def_readwrite("scanlines", &P::scanlines)
      .def_readwrite("line_length", &P::line_length)
      .def_readwrite("line_spacing", &P::line_spacing)
      .def_readwrite("sector_angle", &P::sector_angle)
      .def_readwrite("radius", &P::radius)
      .def_readwrite("width", &P::width)
      .def_readwrite("height", &P::height)
      .def_readwrite("sampling_frequency", &P::sampling_frequency)
      .def_readwrite("radial_decimation", &P::radial_decimation)
      .def_readwrite("center_frequency", &P::center_frequency)
      .def_readwrite("fractional_bandwidth", &P::fractional_bandwidth)
      .def_readwrite("lateral_beam_width", &P::lateral_beam_width)
      .def_readwrite("elevational_beam_width", &P::elevational_beam_width)
      .def_readwrite("speed_of_sound", &P::speed_of_sound)
      .def_readwrite("metres_per_unit", &P::metres_per_unit)
      .def_readwrite("dynamic_range", &P::dynamic_range)
      .def_readwrite("gain", &P::gain)
      .def_readwrite("time_gain_compensation", &P::time_gain_compensation)
      .def_readwrite("focal_depth", &P::focal_depth)
      .def_readwrite("coupling_impedance", &P::coupling_impedance)
      .def_readwrite("specular_amplitude", &P::specular_amplitude)
      .def_readwrite("rf_output", &P::rf_output);

  using I = scene::UltrasoundInclusion;
  py::class_<I>(m, "UltrasoundInclusion",
                "A sphere in a tissue (entity frame) whose scatterer amplitudes are scaled: 0 anechoic, < 1 "
                "hypoechoic, > 1 hyperechoic.")
      .def(py::init([](scene::Vec3 c, float r, float a) { return I{c, r, a}; }), py::arg("center"),
           py::arg("radius"), py::kw_only(), py::arg("amplitude_scale") = 0.f)
      .def_readwrite("center", &I::center)
      .def_readwrite("radius", &I::radius)
      .def_readwrite("amplitude_scale", &I::amplitude_scale);

  using T = scene::UltrasoundTissue;
  py::class_<T>(m, "UltrasoundTissue",
                "Ultrasound scatterers of a tissue, made at prepare() in the entity frame and carried by its pose, "
                "or, on an entity with a tetrahedral SoftBody, inside its tets and carried by its particles. "
                "Keyword fields: region ('box', 'sphere', 'cylinder'; not used on a SoftBody), size (box half "
                "extents; sphere radius in x; cylinder radius x, half height y along z), center, density (per "
                "cubic scene unit) or count, amplitude_mean, amplitude_std (normal amplitudes), inclusions, seed, "
                "attenuation (dB/cm/MHz, default 0.5), impedance (MRayl, default 1.63; a rigid tissue's region is "
                "the medium its scanlines cross: attenuation along the way, echoes and shadows at its boundaries).")
      .def(py::init([](py::kwargs kw) { return from_keywords<T>("UltrasoundTissue", kw); }))
      .def_property("region",
                    [](const T& t) {
                      return t.region == RegionKind::SPHERE ? "sphere" : t.region == RegionKind::CYLINDER ? "cylinder" : "box";
                    },
                    [](T& t, const std::string& k) {
                      t.region = parse_enum<RegionKind>(k, {{"box", RegionKind::BOX}, {"sphere", RegionKind::SPHERE},
                                                            {"cylinder", RegionKind::CYLINDER}},
                                                        "UltrasoundTissue region");
                    })
      .def_readwrite("size", &T::size)
      .def_readwrite("center", &T::center)
      .def_readwrite("density", &T::density)
      .def_readwrite("count", &T::count)
      .def_readwrite("amplitude_mean", &T::amplitude_mean)
      .def_readwrite("amplitude_std", &T::amplitude_std)
      .def_readwrite("inclusions", &T::inclusions)
      .def_readwrite("seed", &T::seed)
      .def_readwrite("attenuation", &T::attenuation)
      .def_readwrite("impedance", &T::impedance);
}

}  // namespace

void bind_scene(py::module_& m) {
  py::class_<scene::SceneLayout>(m, "SceneLayout")
      .def(py::init([](uint32_t num_envs, uint32_t r, uint32_t l, uint32_t c) {
             scene::SceneLayout s{num_envs, r, l, c};
             s.validate();
             return s;
           }),
           py::arg("num_envs"), py::kw_only(), py::arg("max_renderables_per_env") = 16,
           py::arg("max_lights_per_env") = 4, py::arg("max_cameras_per_env") = 4)
      .def_readonly("num_envs", &scene::SceneLayout::num_envs)
      .def_readonly("max_renderables_per_env", &scene::SceneLayout::max_renderables_per_env)
      .def_readonly("max_lights_per_env", &scene::SceneLayout::max_lights_per_env)
      .def_readonly("max_cameras_per_env", &scene::SceneLayout::max_cameras_per_env)
      .def("__repr__", [](const scene::SceneLayout& s) {
        return "SceneLayout(num_envs=" + std::to_string(s.num_envs) + ", max_renderables_per_env=" +
               std::to_string(s.max_renderables_per_env) + ", max_lights_per_env=" +
               std::to_string(s.max_lights_per_env) + ", max_cameras_per_env=" +
               std::to_string(s.max_cameras_per_env) + ")";
      });

  bind_physics_components(m);
  bind_render_components(m);
  bind_sensor_components(m);

  py::class_<scene::Transform>(m, "Transform")
      .def(py::init([](std::array<float, 3> p, std::array<float, 4> r, std::array<float, 3> s) {
             return scene::Transform{p, r, s};
           }),
           py::kw_only(), py::arg("position") = std::array<float, 3>{0, 0, 0},
           py::arg("rotation") = std::array<float, 4>{0, 0, 0, 1}, py::arg("scale") = std::array<float, 3>{1, 1, 1},
           "Pose of an entity; rotation is a quaternion (x, y, z, w).")
      .def_readwrite("position", &scene::Transform::position)
      .def_readwrite("rotation", &scene::Transform::rotation)
      .def_readwrite("scale", &scene::Transform::scale)
      .def("__repr__", [](const scene::Transform& t) {
        return py::str("Transform(position={}, rotation={}, scale={})")
            .format(py::cast(t.position), py::cast(t.rotation), py::cast(t.scale));
      });

  py::class_<Entity>(m, "Entity")
      .def_property_readonly("id", [](const Entity& e) { return e.id; })
      .def_property_readonly("env", [](const Entity& e) { return e.world->env_of(e.id); })
      .def_property_readonly("name", [](const Entity& e) { return e.world->name_of(e.id); })
      .def("add", &add<scene::Transform>, py::arg("component"),
           "Attaches a component (a topology change: prepare() again if already uploaded). Replacing a "
           "Transform only changes its value (as entity.transform = ...).")
      .def("add", &add<scene::RigidBody>, py::arg("component"))
      .def("add", &add<scene::Collider>, py::arg("component"))
      .def("add", &add<scene::Joint>, py::arg("component"))
      .def("add", &add<scene::Renderable>, py::arg("component"))
      .def("add", &add<scene::Camera>, py::arg("component"))
      .def("add", &add<scene::Light>, py::arg("component"))
      .def("add", &add<scene::UltrasoundProbe>, py::arg("component"))
      .def("add", &add<scene::UltrasoundTissue>, py::arg("component"))
      .def("add", &add<scene::EnvironmentLight>, py::arg("component"))
      .def("has", [](const Entity& e, py::object type) {
        if (type.is(py::type::of<scene::Transform>())) return e.world->has<scene::Transform>(e.id);
        if (type.is(py::type::of<scene::RigidBody>())) return e.world->has<scene::RigidBody>(e.id);
        if (type.is(py::type::of<scene::Collider>())) return e.world->has<scene::Collider>(e.id);
        if (type.is(py::type::of<scene::Joint>())) return e.world->has<scene::Joint>(e.id);
        if (type.is(py::type::of<scene::Renderable>())) return e.world->has<scene::Renderable>(e.id);
        if (type.is(py::type::of<scene::Material>())) return e.world->has<scene::Material>(e.id);
        if (type.is(py::type::of<scene::Camera>())) return e.world->has<scene::Camera>(e.id);
        if (type.is(py::type::of<scene::Light>())) return e.world->has<scene::Light>(e.id);
        if (type.is(py::type::of<scene::UltrasoundProbe>())) return e.world->has<scene::UltrasoundProbe>(e.id);
        if (type.is(py::type::of<scene::UltrasoundTissue>())) return e.world->has<scene::UltrasoundTissue>(e.id);
        if (type.is(py::type::of<scene::EnvironmentLight>())) return e.world->has<scene::EnvironmentLight>(e.id);
        throw py::type_error("unknown component type");
      })
      .def_property(
          "transform", [](const Entity& e) { return e.world->get<scene::Transform>(e.id); },
          [](Entity& e, const scene::Transform& t) { e.world->set(e.id, t); },
          "Reading copies; assigning changes the value only (uploaded before the next frame). A dynamic "
          "rigid body jumps there; a kinematic one moves there over the next step.")
      .def_property_readonly("rigid_body", [](const Entity& e) { return e.world->get<scene::RigidBody>(e.id); })
      .def_property_readonly("collider", [](const Entity& e) { return e.world->get<scene::Collider>(e.id); })
      .def_property_readonly("joint", [](const Entity& e) { return e.world->get<scene::Joint>(e.id); })
      .def_property_readonly("renderable", [](const Entity& e) { return e.world->get<scene::Renderable>(e.id); })
      .def_property_readonly("light", [](const Entity& e) { return e.world->get<scene::Light>(e.id); })
      .def("__repr__", [](const Entity& e) { return "<Entity " + e.world->describe(e.id) + ">"; });

  py::class_<scene::World, std::shared_ptr<scene::World>>(m, "World")
      .def(py::init<scene::SceneLayout>(), py::arg("layout"))
      .def_property_readonly("layout", &scene::World::layout)
      .def("create_entity",
           [](std::shared_ptr<scene::World> w, uint32_t env, const std::string& name) {
             return Entity{w, w->create_entity(env, name)};
           },
           py::arg("env"), py::arg("name") = "")
      .def("entity", [](std::shared_ptr<scene::World> w, scene::EntityId id) {
        w->env_of(id);  // validates
        return Entity{w, id};
      })
      .def("add_mesh", &scene::World::add_mesh, py::arg("mesh"), "Adds a shared mesh; returns its index.")
      .def("add_texture", &scene::World::add_texture, py::arg("texture"),
           "Adds a shared texture (cressim.Texture); returns its index for Renderable.texture.")
      .def("set_source", &scene::World::set_source, py::arg("entity"), py::arg("field"), py::arg("where"),
           "Records where a field was authored (e.g. 'scene.yaml:12'); errors about it start with that. field: "
           "'' the entity, 'Collider' a component, 'Collider.shapes[0].size' a field.")
      .def("source_of", &scene::World::source_of, py::arg("entity"), py::arg("field") = "",
           "The most specific recorded source for the field (its own, else its parent's ...), or ''.")
      .def_property_readonly("entity_count", &scene::World::entity_count)
      .def_property_readonly("topology_version", &scene::World::topology_version);
}

}  // namespace cressim::python
