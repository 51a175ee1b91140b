// Components an entity can carry. Adding a kind: define its struct here and list it in
// ComponentTypes; World stores it, prepare() maps it, and the binding exposes it.
#pragma once
#include <array>
#include <cstdint>
#include <limits>
#include <string>
#include <tuple>
#include <vector>

namespace cressim::scene {

using Vec3 = std::array<float, 3>;
using Quat = std::array<float, 4>;  // x, y, z, w

struct Transform {
  Vec3 position{0, 0, 0};
  Quat rotation{0, 0, 0, 1};
  Vec3 scale{1, 1, 1};
};

// A dynamic (or kinematic) rigid body; its centre of mass is the entity origin.
// mass 0: density times the volume of the entity's collider shapes; inertia 0: from the shapes.
struct RigidBody {
  float mass = 0;
  float density = 1000;
  Vec3 inertia{0, 0, 0};  // principal moments in the body frame
  bool kinematic = false;  // moved to targets (entity.transform or control.body_targets), never by forces
  float linear_damping = 0;
  float angular_damping = 0;
};

enum class ShapeKind : uint32_t { NONE = 0, SPHERE = 1, BOX = 2, CAPSULE = 3, PLANE = 4 };

struct Shape {
  ShapeKind kind = ShapeKind::NONE;
  Vec3 size{0, 0, 0};  // box half extents; sphere radius in x; capsule radius x, half height y (along z)
  Vec3 position{0, 0, 0};  // in the entity frame
  Quat rotation{0, 0, 0, 1};
};

// Collision shapes of an entity: of its rigid body, or static when it has none. Several small
// spheres make a proxy-particle collider. Pairs collide when (group_a & mask_b) && (group_b & mask_a).
struct Collider {
  std::vector<Shape> shapes;
  float static_friction = 0.5f;
  float dynamic_friction = 0.5f;
  float restitution = 0;
  uint32_t group = 1;
  uint32_t mask = 0xffffffffu;
};

enum class JointKind : uint32_t { NONE = 0, FIXED = 1, BALL = 2, SPHERICAL = 3, HINGE = 4, SLIDER = 5 };
enum class DriveMode : uint32_t { NONE = 0, POSITION = 1, VELOCITY = 2 };

// A joint between two rigid-body entities of one env (body_a -1: the world). Anchor and axis are
// given in world coordinates at the authored poses; the joint coordinate (hinge angle, slider
// offset) is 0 there.
struct Joint {
  JointKind kind = JointKind::NONE;
  int64_t body_a = -1;
  int64_t body_b = -1;
  Vec3 anchor{0, 0, 0};
  Vec3 axis{1, 0, 0};
  bool limited = false;
  float lower = 0, upper = 0;
  DriveMode drive = DriveMode::NONE;
  float target = 0;  // position or velocity target (control.joint_targets at upload)
  Quat target_rotation{0, 0, 0, 1};  // spherical drive
  float stiffness = 0, damping = 0;
  float max_force = std::numeric_limits<float>::infinity();
  float compliance = 0;  // of the attachment itself (0: rigid)
  bool collide_connected = false;
};

// Drawn by the cameras of its env: a mesh of the world's mesh table (world.add_mesh), scaled
// by the entity's Transform.scale. segmentation_id 0: the entity id + 1 (0 is background).
// Material: metallic/roughness (GGX); texture: a world.add_texture index (-1: none) whose
// colour multiplies `color`, sampled at the mesh's uvs.
struct Renderable {
  uint32_t mesh = 0;
  std::array<float, 4> color{0.8f, 0.8f, 0.8f, 1.0f};  // linear RGBA
  float metallic = 0, roughness = 0.5f;
  uint32_t segmentation_id = 0;
  int32_t texture = -1;
  // tangent-space normals (RGB = xyz * 0.5 + 0.5, green toward the image's top), linear texels;
  // normal_scale scales their x and y (0: flat, as without a map)
  int32_t normal_map = -1;
  float normal_scale = 1;
};

// The look of a particle object (SoftBody, Strand, Fluid on the same entity), which the
// renderer draws from the physics buffers. segmentation_id 0: the entity id + 1. A fluid's
// colour is what 2 cm of it shows over white (its absorption follows from that).
struct Material {
  std::array<float, 4> color{0.8f, 0.8f, 0.8f, 1.0f};  // linear RGBA
  float metallic = 0, roughness = 0.5f;
  uint32_t segmentation_id = 0;
};

// What a camera writes (bits of Camera.products): fewer outputs, less memory and bandwidth.
enum CameraProduct : uint32_t { PRODUCT_RGB = 1, PRODUCT_DEPTH = 2, PRODUCT_SEGMENTATION = 4, PRODUCT_ALL = 7 };

// A pinhole camera looking along the entity's +z, x right, y down (optical frame).
// fx, fy 0: from fov_y (degrees); cx, cy < 0: the image centre.
struct Camera {
  uint32_t width = 64, height = 64;
  float fov_y = 50;
  float fx = 0, fy = 0, cx = -1, cy = -1;
  float near = 0.01f, far = 100;
  uint32_t products = PRODUCT_ALL;
};

enum class LightKind : uint32_t { DIRECTIONAL = 1, POINT = 2, SPOT = 3 };

// A light at the entity's pose: directional lights travel along the entity's +z, spots point
// along it, point and spot lights sit at its origin. Intensity: a white matte surface facing a
// directional light of intensity 1 (or a point light of intensity 1 at 1 m) shows `color`.
// The env's first light with `shadows` (directional) casts shadows over a square of half-size
// shadow_extent around the light entity, at shadow_resolution texels a side.
struct Light {
  Vec3 color{1, 1, 1};
  float intensity = 1;
  float ambient = 0.2f;  // the env's uniform ambient (its first light's) without an EnvironmentLight
  LightKind kind = LightKind::DIRECTIONAL;
  float range = 0;  // point/spot: 0 unlimited, else falls smoothly to 0 there
  float inner_angle = 20, outer_angle = 30;  // spot half-angles, degrees
  bool shadows = false;
  float shadow_extent = 2;
  uint32_t shadow_resolution = 256;
};

// The env's ambient light: a hemisphere, `sky` from +z and `ground` from -z (per env); or,
// with `map` (a World texture, equirectangular), image-based lighting from that map
// (render/environment_map.h).
struct EnvironmentLight {
  Vec3 sky{0.2f, 0.2f, 0.2f};
  Vec3 ground{0.2f, 0.2f, 0.2f};
  float intensity = 1;
  int32_t map = -1;  // texture index, -1: none (the hemisphere)
};


enum class ProbeKind : uint32_t { NONE = 0, LINEAR = 1, SECTOR = 2 };

// An ultrasound probe (COLE B-mode synthesis) on the entity's face: it looks along +z, spreads
// its scanlines along x, and y is the elevation. Lengths are scene units; metres_per_unit
// relates them to the pulse (frequencies, speed of sound). The defaults are an abdominal
// curvilinear probe in a scene in metres: 3.5 MHz, 60 degrees, 15 cm deep.
struct UltrasoundProbe {
  ProbeKind kind = ProbeKind::SECTOR;
  uint32_t scanlines = 128;
  float line_length = 0.15f;     // imaged depth along each scanline
  float line_spacing = 0.0003f;  // linear: between neighbouring scanlines
  float sector_angle = 60;       // sector: degrees from the first scanline to the last
  float radius = 0.05f;          // sector: radius of the curved face (0: a phased array)
  uint32_t width = 256, height = 200;   // output image, pixels (square at the defaults)
  float sampling_frequency = 40e6f;     // Hz, of the RF the IQ samples are decimated from
  uint32_t radial_decimation = 8;       // IQ samples keep every n-th RF sample
  float center_frequency = 3.5e6f;      // Hz
  float fractional_bandwidth = 0.6f;    // -6 dB bandwidth over the centre frequency
  float lateral_beam_width = 0.0015f;   // FWHM of the two-way beam profile
  float elevational_beam_width = 0.004f;
  float speed_of_sound = 1540;          // m/s
  float metres_per_unit = 1;            // metres in one scene unit
  float dynamic_range = 50;             // dB shown from white to black
  float gain = -25;                     // dB; envelope 1 (after gain) is white
  float time_gain_compensation = 0;     // dB per cm of depth added back (attenuation x 2 x f0 flattens)
  float focal_depth = 0;                // beam narrowest (the widths above) here; 0: no focus, widths constant
  float coupling_impedance = 1.63f;     // MRayl, of the medium outside every tissue (gel matched to soft tissue)
  float specular_amplitude = 1000;      // echo of a perfect plane reflector (r = 1), in scatterer amplitudes
  bool rf_output = false;               // also fill "ultrasound0.rf" at the full sampling rate
};

enum class RegionKind : uint32_t { NONE = 0, BOX = 1, SPHERE = 2, CYLINDER = 3 };

// A sphere inside a tissue region (entity frame) whose scatterers' amplitudes are scaled:
// 0 makes an anechoic cyst (no scatterers), 0.3 a hypoechoic lesion, 2 a brighter one.
struct UltrasoundInclusion {
  Vec3 center{0, 0, 0};
  float radius = 0;
  float amplitude_scale = 0;
};

// Scatterers of a tissue, generated at prepare() in the entity frame and carried by its pose
// (a static, kinematic or dynamic body); on an entity with a tetrahedral SoftBody they fill its
// tets instead (region unused) and are carried by the tets' particles, so the image deforms. Region: box half extents, sphere radius (size x),
// cylinder radius x and half height y along z; centred at `center`.
struct UltrasoundTissue {
  RegionKind region = RegionKind::BOX;
  Vec3 size{0.02f, 0.02f, 0.02f};
  Vec3 center{0, 0, 0};
  float density = 0;     // scatterers per cubic scene unit, or
  uint32_t count = 0;    // this many in the region (one of the two)
  float amplitude_mean = 1;   // amplitudes are normal(mean, std)
  float amplitude_std = 0.5f;
  std::vector<UltrasoundInclusion> inclusions;
  uint32_t seed = 0;     // with the entity id: envs get different speckle
  float attenuation = 0.5f;  // dB/cm/MHz, one way (soft tissue about 0.5)
  float impedance = 1.63f;   // MRayl (soft tissue about 1.63, fat 1.38, bone 7.8)
};

// Particle objects (engine/physics/particle_*): positions are in the entity frame at prepare().
// Compliances are XPBD compliances of normalised constraints (strain: |d|/L - 1, V/V0 - 1), so
// stiffness does not depend on the iteration count or, to first order, on the mesh resolution.

// A tetrahedral soft body (tets given) or a meshfree one (no tets: each particle is tied to its
// k nearest neighbours by distance constraints). triangles: the surface for rendering (local
// particle indices); fixed: particles with infinite mass (clamped).
// A tet-meshed body is an elastic material by default: stable Neo-Hookean energy per unit volume
// (Young's modulus, Poisson's ratio), mass from density, solved per vertex (docs/particles.md).
// youngs_modulus = 0 selects the expert model instead: XPBD strain constraints with the given
// compliances and a mass per particle (meshfree bodies always use it).
// Heat in an elastic body (its tets): conduction, heat sources (control.heat_sources) and thermal
// damage by the Arrhenius integral. Defaults: liver (conductivity and specific heat of perfused
// liver; the Arrhenius pair commonly used for liver coagulation), at body temperature.
struct Thermal {
  bool enabled = false;
  float conductivity = 0.52f;      // W/m/K
  float specific_heat = 3540;      // J/kg/K
  float temperature = 310.15f;     // K: where every particle starts (37 C)
  double frequency_factor = 7.39e39;  // A, 1/s (beyond float range: kept as ln A on the GPU)
  double activation_energy = 2.577e5;  // Ea, J/mol
  float damage_onset = 315.15f;    // K: no damage below it (42 C; the fit holds for hyperthermia, not at rest)
  // coagulated tissue (its share 1 - exp(-Omega)): stiffer by this ratio and shrunk by this linear strain
  float coagulated_stiffening = 4.0f;
  float coagulated_shrinkage = 0.1f;
};

struct SoftBody {
  std::vector<float> positions;     // x y z per particle
  std::vector<uint32_t> tets;       // 4 per tetrahedron
  std::vector<uint32_t> triangles;  // 3 per surface triangle
  std::vector<uint32_t> fixed;
  float youngs_modulus = 10e3f;     // Pa (soft tissue: 1e3 .. 1e5); 0: compliance model
  float poisson_ratio = 0.45f;      // in [0, 0.5)
  float density = 1000;             // kg/m^3; the tets' mass, lumped to their corners
  float mass = 0.01f;               // per particle (kg), compliance model
  float distance_compliance = 1e-4f;
  float volume_compliance = 1e-4f;
  uint32_t neighbors = 8;           // meshfree: k
  float damping = 0;                // 1/s
  float radius = 0.02f;             // collision radius (m)
  float friction = 0.5f;
  bool self_collision = false;
  Thermal thermal;                  // heat: elastic bodies only
};

// Position-based fluid (Macklin & Mueller 2013) with `budget` particle slots, of which the given
// positions start active; the rest are inactive until emitted (no reallocation). Spacing 2 x
// radius, kernel support 4 x radius; particle mass from the rest density on that lattice.
struct Fluid {
  std::vector<float> positions;     // x y z per initially active particle
  uint32_t budget = 0;              // slots (0: as many as positions)
  float radius = 0.05f;
  float rest_density = 1000;        // kg/m^3
  float viscosity = 0.01f;          // XSPH coefficient
  float cohesion = 0.0f;            // Akinci et al. 2013 cohesion coefficient
  float surface_tension = 0.0f;     // curvature term coefficient
  float vorticity = 0.0f;           // vorticity confinement epsilon
  float friction = 0.1f;
  float damping = 0;
  // emitter: each frame activates up to emit_rate inactive slots on a square nozzle of
  // emit_width x emit_width lattice points around emit_origin (entity frame), across the
  // emit_velocity direction, moving at emit_velocity (world); it should carry a row clear of
  // the nozzle within a frame (|v| dt >= 2 radius)
  uint32_t emit_rate = 0;
  uint32_t emit_width = 4;
  Vec3 emit_origin{0, 0, 0};
  Vec3 emit_velocity{0, 0, -1};
};

// A thread or cable: a chain of particles, each segment with a material frame (a Cosserat rod,
// Kugelstadt & Schoemer 2016): stretch (distance), stretch-shear (frame along the segment),
// bend and twist (between neighbouring frames; rest straight and untwisted).
struct Strand {
  std::vector<float> points;        // x y z per particle, in order
  std::vector<uint32_t> fixed;
  float mass = 0.001f;              // per particle
  float radius = 0.005f;
  float stretch_compliance = 0;
  float bend_compliance = 1e-3f;
  float twist_compliance = 1e-3f;
  float initial_twist = 0;          // radians from the first segment's frame to the last's, spread evenly
  float damping = 0;
  float friction = 0.3f;
  bool self_collision = false;
  bool soft_body_contacts = true;   // false: passes through soft bodies (a suture thread sewn into tissue)
  // a rod's material (0: the compliances and mass above): bending EI and twist GJ of a solid
  // round section of `radius`, mass density x volume lumped to the particles
  float youngs_modulus = 0;         // Pa
  float poisson_ratio = 0.3f;       // in [0, 0.5)
  float density = 1000;             // kg/m^3
};

// Tendons routed along a Strand (a cable-driven continuum robot), on the Strand's entity: spacer
// disks at some of its particles, each turning with that particle's segment frame, and tendons
// that pass through a hole in every disk (their offset from the backbone, the same in each disk)
// and end at the last. A tendon slides freely through its holes; its length from the first
// disk's hole to the last's is driven per tendon (control.tendon_commands).
struct Tendons {
  std::vector<uint32_t> disks;  // strand particles carrying a disk, increasing; the first is the base
  std::vector<float> holes;     // x y per tendon: its hole in each disk's frame (m)
  float stiffness = 0;          // axial stiffness EA of a tendon (N; 0: inextensible)
};

// A curved suture needle on a rigid body (docs/particles.md, "Suturing"): a circular arc in the
// body frame, in the xy plane of the arc frame (`center`, `rotation`) about its z axis, from the
// tail at angle 0 (on its x axis) to the tip at `arc_angle`, turning counter-clockwise. Where its
// tip crosses a soft body's surface it pushes the surface ahead until that takes `puncture_force`
// or the tip is `puncture_depth` past where it met it, then the surface point is punctured: it lies on the needle and then on the thread (a Strand of
// the same env whose first particle is tied to the tail) and slides along them against Coulomb
// friction on the needle (on the thread only with squeeze > 0: capstan friction over its turn there
// plus the squeeze); the thread's last particle is a knot that does not pass a puncture.
struct Needle {
  float arc_radius = 0.008f;         // m (a 16 mm 3/8 circle needle by default)
  float arc_angle = 2.35619449f;     // rad, tail to tip (3/8 of a turn)
  Vec3 center{0, 0, 0};              // the arc's centre in the body frame (m)
  Quat rotation{0, 0, 0, 1};         // the arc's frame in the body frame
  int64_t thread = -1;               // the Strand entity tied to the tail (-1: none)
  float puncture_force = 1.0f;       // N: the surface gives way when it takes this push ...
  float puncture_depth = 0.002f;     // m: ... or when the tip is this far past where it met it
  float friction = 0.3f;             // Coulomb coefficient of thread and needle in the tissue
  float squeeze = 0.0f;              // N: the tissue's grip on the thread (> 0: friction on the thread)
  uint32_t max_punctures = 8;        // puncture records of this needle
};

using ComponentTypes = std::tuple<Transform, RigidBody, Collider, Joint, Renderable, Material, Camera, Light, EnvironmentLight,
                                  UltrasoundProbe, UltrasoundTissue, SoftBody, Fluid, Strand, Tendons, Needle>;

// The name errors use for a component kind ("Collider"), as the binding spells it.
template <class C>
constexpr const char* component_name();
template <> constexpr const char* component_name<Transform>() { return "Transform"; }
template <> constexpr const char* component_name<RigidBody>() { return "RigidBody"; }
template <> constexpr const char* component_name<Collider>() { return "Collider"; }
template <> constexpr const char* component_name<Joint>() { return "Joint"; }
template <> constexpr const char* component_name<Renderable>() { return "Renderable"; }
template <> constexpr const char* component_name<Material>() { return "Material"; }
template <> constexpr const char* component_name<Camera>() { return "Camera"; }
template <> constexpr const char* component_name<Light>() { return "Light"; }
template <> constexpr const char* component_name<EnvironmentLight>() { return "EnvironmentLight"; }
template <> constexpr const char* component_name<UltrasoundProbe>() { return "UltrasoundProbe"; }
template <> constexpr const char* component_name<UltrasoundTissue>() { return "UltrasoundTissue"; }
template <> constexpr const char* component_name<SoftBody>() { return "SoftBody"; }
template <> constexpr const char* component_name<Fluid>() { return "Fluid"; }
template <> constexpr const char* component_name<Strand>() { return "Strand"; }
template <> constexpr const char* component_name<Tendons>() { return "Tendons"; }
template <> constexpr const char* component_name<Needle>() { return "Needle"; }

// Triangle meshes shared by all envs; vertex normals per vertex.
struct Mesh {
  std::vector<float> positions;  // x y z per vertex
  std::vector<float> normals;    // x y z per vertex
  std::vector<uint32_t> indices;  // three per triangle
  std::vector<float> uvs;        // u v per vertex (texture coordinates), or none
  // when set: the vertex positions are copied every frame on the GPU from this engine buffer
  // (float4 rows, one per vertex, e.g. a particle system's surface), and normals come from the
  // triangles; `positions` then only give the vertex count and the bounds
  std::string positions_key;
  uint32_t vertex_count() const { return uint32_t(positions.size() / 3); }
};

// An RGBA8 image for Renderable.texture (world.add_texture), rows top to bottom; it wraps.
struct Texture {
  uint32_t width = 0, height = 0;
  std::vector<uint8_t> rgba;  // 4 bytes per texel
};

}  // namespace cressim::scene
