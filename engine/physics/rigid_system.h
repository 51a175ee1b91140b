// The rigid-body system on the GPU: its buffers (state, model, control, scratch), the step
// recorded into step_physics and the per-env reset recorded into the frame's first stage.
#pragma once
#include <map>
#include <memory>
#include <string>

#include "compute/compute_pass.h"
#include "physics/rigid_model.h"
#include "physics/settings.h"

namespace cressim::physics {

using BufferMap = compute::BufferMap;

class RigidSystem {
 public:
  // internal: read-only engine buffers (keys added); control: writable ones (keys added).
  // scene: the engine's transform buffers and env flags the system reads and writes.
  RigidSystem(std::shared_ptr<gpu::Context> ctx, RigidModel model, const PhysicsSettings& settings,
              uint64_t generation, BufferMap& internal, BufferMap& control, const BufferMap& scene);

  // max_contacts_per_env sizes a buffer: it can change only with a new upload_world()
  void set_settings(const PhysicsSettings& s);
  void record_step(VkCommandBuffer cmd) const { step_->record(cmd); }
  void record_reset(VkCommandBuffer cmd) const { reset_->record(cmd); }
  const RigidModel& model() const { return model_; }
  // envs flagged unhealthy (and reset) since upload_world(), read from host-visible memory
  uint64_t health_events(const BufferMap& internal) const;
  int64_t body_of(uint32_t entity) const { return entity < model_.entity_body.size() ? model_.entity_body[entity] : -1; }

 private:
  RigidModel model_;
  uint32_t max_contacts_ = 0;
  std::shared_ptr<compute::ComputePass> step_, reset_;
};

}  // namespace cressim::physics
