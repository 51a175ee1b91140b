#include "runtime/frame.h"

#include "compute/compute_pass.h"

namespace cressim::runtime {

const char* stage_name(Stage s) {
  switch (s) {
    case Stage::UPLOAD: return "upload";
    case Stage::RESET: return "reset_flagged_envs";
    case Stage::PHYSICS: return "step_physics";
    case Stage::VISUAL_SENSORS: return "step_visual_sensors";
    case Stage::SIMULATION_SENSORS: return "step_simulation_sensors";
    case Stage::CUSTOM_PASS: return "execute_compute_pass";
    default: return "none";
  }
}

std::string FrameOp::label() const {
  if (stage == Stage::CUSTOM_PASS && pass) return "pass '" + pass->name + "'";
  return stage_name(stage);
}

}  // namespace cressim::runtime
