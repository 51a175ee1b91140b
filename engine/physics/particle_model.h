// prepare() for particles: SoftBody / Fluid / Strand components flattened into one particle
// array (envs contiguous, objects in entity order within an env), the per-object and per-env
// ranges, the constraint sets of every family grouped by colour, and the surface
// triangles kept for rendering.
#pragma once
#include <cstdint>
#include <cmath>
#include <string>
#include <vector>

#include "cressim/particle.h"
#include "scene/layout_mapping.h"
#include "scene/world.h"

namespace cressim::physics {

// One constraint family's records and the pass that projects them (shaders/<shader>.comp.hlsl,
// one colour per dispatch; see particle_distance.comp.hlsl). Records are grouped by colour and,
// inside a colour, by env; a record's object is the object of its first particle
// (particles.phases[i].y). Families that move positions only also have a `<shader>.block` pass:
// one workgroup per env projects all colours (particle_solve.hlsli).
// A family with `chains` is solved along chains instead (particle_bend_twist.comp.hlsl): each
// chain's records, consecutive and in chain order, are solved together by one thread (a direct
// tridiagonal solve), so colours do not apply (one colour holds all records).
struct ConstraintSet {
  std::string name;    // buffer key particles.<name>_constraints
  std::string shader;  // built-in pass
  std::vector<shader::ParticleConstraint> records;
  uint32_t multipliers = 1;             // XPBD multipliers per record (particles.<name>_lambdas)
  std::vector<uint32_t> chains;         // (first record, count) of each chain, for chain-solved families
  std::vector<uint32_t> colour_offset, colour_count;  // each colour's slice of records
  // (first, count) of each env's records per colour, env-major; vertex-solved families: of each
  // env's particles per vertex colour, into `vertices`
  std::vector<uint32_t> env_colours;
  std::vector<uint32_t> object_count;  // constraints of each object
  // A vertex-solved family (particle_tet.comp.hlsl) is solved per particle instead: each thread
  // moves one particle by a Newton step on the energy of the records around it, so particles are
  // coloured (no two of a colour share a record) and records are not.
  std::vector<shader::float4> record_rows;      // rows_per_record extra rows of each record
  uint32_t rows_per_record = 0;
  std::vector<uint32_t> vertices;               // the solved particles, grouped by colour
  std::vector<uint32_t> vertex_colour_offset, vertex_colour_count;
  std::vector<uint32_t> vertex_records;         // (first, count) into vertex_corners, per entry of `vertices`
  std::vector<uint32_t> vertex_corners;         // record * 4 + corner of the particle in it
};

struct ParticleModel {
  std::vector<shader::float4> positions;   // xyz, w inverse mass
  std::vector<shader::float4> velocities;
  std::vector<shader::uint4> phases;       // x kind, y object, z env, w flags
  // strand segments: material frame (quaternion whose z is the segment), inverse inertia, first particle
  std::vector<shader::float4> orientations;
  std::vector<float> orientation_weights;
  // rods of a material: the bending compliance at each frame (alpha = l / 4 E I, 1/N m; 0: a thread)
  std::vector<float> frame_bend_compliances;
  std::vector<uint32_t> edge_particles;
  std::vector<shader::ParticleObject> objects;
  std::vector<uint32_t> object_entity;
  std::vector<shader::ParticleEnvRange> env_ranges;
  std::vector<ConstraintSet> sets;
  std::vector<uint32_t> surface;           // 3 global particle indices per triangle
  std::vector<uint32_t> surface_offset, surface_count;  // each object's triangles
  float cell_size = 0;                     // neighbour grid: max of fluid kernel support and contact reach
  bool has_fluid = false, has_contacts = false, has_emitters = false;
  // heat (elastic bodies with a Thermal): the largest stable step of explicit conduction, min over
  // particles of m c / K_ii (K the conductance matrix of the tets); infinite without heat
  bool has_heat = false;
  float heat_step_limit = INFINITY;
  std::vector<float> heat_capacities;      // m c per particle (J/K; 0: no heat), as long as positions when has_heat
  // tendon-driven strands (scene::Tendons): per Tendons component, its disks and tendons
  std::vector<shader::TendonRobot> tendon_robots;
  std::vector<uint32_t> tendon_disks;      // (particle, frame) per disk
  std::vector<shader::Tendon> tendons;
  // suture needles (scene::Needle): ids.x is the entity until the engine resolves its rigid body
  std::vector<shader::NeedleModel> needles;
  uint32_t puncture_records = 0;

  size_t size() const { return positions.size(); }
  bool empty() const { return positions.empty(); }
  const ConstraintSet* set(const std::string& name) const;
};

ParticleModel build_particle_model(const scene::World& world, const scene::LayoutMapping& mapping);

// fluid kernels (shared with the passes in particle_fluid.hlsli): support = 4 x radius, spacing = 2 x radius
float fluid_support(float radius);
float fluid_particle_mass(float radius, float rest_density);

}  // namespace cressim::physics
