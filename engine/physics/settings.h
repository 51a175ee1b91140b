// Solver settings: time step, substeps, iterations, gravity, and the health bounds.
#pragma once
#include <array>
#include <cstdint>
#include <string>

namespace cressim::physics {

struct PhysicsSettings {
  float dt = 1.0f / 60.0f;      // frame time step (s)
  uint32_t substeps = 4;        // XPBD substeps per frame
  uint32_t iterations = 1;      // constraint passes per substep (substeps beat iterations)
  std::array<float, 3> gravity{0, 0, -9.81f};  // z up
  uint32_t max_contacts_per_env = 64;
  float max_speed = 100;        // m/s beyond which an env is unhealthy and reset
  float max_penetration = 0.25f;  // m
  uint32_t particle_iterations = 4;  // particle constraint passes per substep (XPBD: compliance holds whatever the count)
  uint32_t max_particle_attachments_per_env = 4;  // rigid-particle attachment slots (control.particle_attachments)
  // of the particle_iterations, how many also solve contacts, fluid density and attachments
  // (0: all); the constraint families run every iteration (the paper's "internal" vs "contact")
  uint32_t particle_contact_iterations = 0;
  // constraint families: "dispatch" (one dispatch per colour), "workgroup" (one workgroup per env
  // solves all colours in group memory; envs of at most PARTICLE_BLOCK_CAPACITY particles; where
  // only distance and volume families, contacts, colliders and attachments act, or fluid alone,
  // the whole substep's iterations in one: docs/particles.md), or "auto" (workgroup where every
  // env fits)
  std::string particle_solver = "auto";
  // particle substeps per frame (0: `substeps`). Fewer than the bodies' when only the bodies need
  // the short step (a jointed arm of gram-light wrist links holding tissue): the particles then
  // see the bodies where they are at the end of each of their own substeps.
  uint32_t particle_substeps = 0;

  uint32_t particle_substep_count() const { return particle_substeps ? particle_substeps : substeps; }
  void validate() const;
};

}  // namespace cressim::physics
