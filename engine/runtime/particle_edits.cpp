// Run-time edits of the particle system from the host, all through writable control buffers
// (no reallocation, applied at the next step): strand frames held by attachments, fluid
// removal, and cutting constraints. Task passes can write the same buffers on the GPU.
#include <algorithm>
#include <cmath>

#include "runtime/engine.h"

namespace cressim::runtime {

void Engine::hold_frame_of(shader::ParticleAttachment& a, const std::optional<std::array<float, 4>>& offset) const {
  const auto& pm = particles_->model();
  const uint32_t particle = a.ids.x;
  if (pm.phases[particle].x != shader::PARTICLE_STRAND)
    throw std::invalid_argument("attach_particle: hold_frame needs a strand particle; particle " + std::to_string(particle) +
                                " is not one");
  // the segment that starts at the particle, or else the one that ends there (a strand's last particle)
  const auto& edges = pm.edge_particles;
  auto it = std::lower_bound(edges.begin(), edges.end(), particle);
  if (it == edges.end() || *it != particle) {
    it = std::lower_bound(edges.begin(), edges.end(), particle - 1);
    if (particle == 0 || it == edges.end() || *it != particle - 1)
      throw std::logic_error("attach_particle: strand particle " + std::to_string(particle) + " has no segment");
  }
  a.hold = {uint32_t(it - edges.begin()), shader::HOLD_FRAME_CAPTURE, 0, 0};
  if (!offset) return;
  const auto& q = *offset;
  const float len = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (!(len > 1e-6f) || !std::isfinite(len))
    throw std::invalid_argument("attach_particle: frame_offset must be a nonzero quaternion (x, y, z, w)");
  a.frame = {q[0] / len, q[1] / len, q[2] / len, q[3] / len};
  a.hold.y = shader::HOLD_FRAME_GIVEN;
}

void Engine::remove_particles(const std::vector<uint32_t>& particles) {
  require_current_topology("remove_particles()");
  if (particles.empty()) return;
  if (!particles_) throw std::invalid_argument("remove_particles: the scene has no particles");
  const auto& pm = particles_->model();
  auto& flags = *shared_.at("control.particle_remove");
  const uint32_t one = 1;
  for (uint32_t p : particles) {
    if (p >= pm.size())
      throw std::out_of_range("remove_particles: particle " + std::to_string(p) + " is out of range (" +
                              std::to_string(pm.size()) + " particles)");
    if (pm.phases[p].x != shader::PARTICLE_FLUID)
      throw std::invalid_argument("remove_particles: particle " + std::to_string(p) + " (env " +
                                  std::to_string(pm.phases[p].z) + ", " +
                                  world_->describe(pm.object_entity[pm.phases[p].y]) +
                                  ") is not a fluid particle; only fluid slots can be removed");
  }
  for (uint32_t p : particles) write_rows(flags, p, &one, 4);
}

void Engine::cut_constraints(const std::string& family, const std::vector<uint32_t>& rows, bool cut) {
  require_current_topology("cut_constraints()");
  const physics::ConstraintSet* set = particles_ ? particles_->model().set(family) : nullptr;
  if (!set) {
    std::string names;
    if (particles_)
      for (auto& s : particles_->model().sets) names += (names.empty() ? "" : ", ") + s.name;
    throw std::invalid_argument("cut_constraints: no constraint family '" + family + "' (" +
                                (particles_ ? "families: " + names : std::string("the scene has no particles")) + ")");
  }
  auto& flags = *shared_.at("control.particle_" + family + "_cut");
  const uint32_t value = cut ? 1 : 0;
  for (uint32_t r : rows) {
    if (r >= set->records.size())
      throw std::out_of_range("cut_constraints: row " + std::to_string(r) + " of particles." + family +
                              "_constraints is out of range (" + std::to_string(set->records.size()) + " rows)");
  }
  for (uint32_t r : rows) write_rows(flags, r, &value, 4);
}

}  // namespace cressim::runtime
