// How many environments a batched scene has and what each may hold (fixed-capacity slots).
#pragma once
#include <cstdint>
#include <stdexcept>
#include <string>

namespace cressim::scene {

struct SceneLayout {
  uint32_t num_envs = 1;
  uint32_t max_renderables_per_env = 16;
  uint32_t max_lights_per_env = 4;
  uint32_t max_cameras_per_env = 4;

  void validate() const {
    if (num_envs == 0) throw std::invalid_argument("SceneLayout: num_envs must be at least 1");
  }
};

}  // namespace cressim::scene
