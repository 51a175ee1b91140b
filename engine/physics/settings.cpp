#include "physics/settings.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace cressim::physics {

void PhysicsSettings::validate() const {
  auto fail = [](const std::string& field, const std::string& why) {
    throw std::invalid_argument("PhysicsSettings." + field + ": " + why);
  };
  if (!(dt > 0) || !std::isfinite(dt)) fail("dt", "must be a positive number of seconds");
  if (substeps < 1 || substeps > 256) fail("substeps", "must be 1..256");
  if (iterations < 1 || iterations > 64) fail("iterations", "must be 1..64");
  for (float g : gravity)
    if (!std::isfinite(g)) fail("gravity", "must be finite");
  if (max_contacts_per_env > 4096) fail("max_contacts_per_env", "must be at most 4096");
  if (!(max_speed > 0)) fail("max_speed", "must be positive");
  if (!(max_penetration > 0)) fail("max_penetration", "must be positive");
  if (particle_iterations < 1 || particle_iterations > 256) fail("particle_iterations", "must be 1..256");
  if (particle_contact_iterations > particle_iterations)
    fail("particle_contact_iterations", "must be at most particle_iterations (" + std::to_string(particle_iterations) +
                                            "); 0 means all of them");
  if (particle_solver != "auto" && particle_solver != "dispatch" && particle_solver != "workgroup")
    fail("particle_solver", "'" + particle_solver + "' is not one of auto, dispatch, workgroup");
  if (particle_substeps > 256) fail("particle_substeps", "must be 0..256 (0: the same as substeps)");
  if (max_particle_attachments_per_env > 4096) fail("max_particle_attachments_per_env", "must be at most 4096");
}

}  // namespace cressim::physics
