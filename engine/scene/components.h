// Components an entity can carry. Adding a kind: define its struct here and list it in
// ComponentTypes; World stores it, prepare() maps it, and the binding exposes it.
#pragma once
#include <array>
#include <tuple>

namespace cressim::scene {

struct Transform {
  std::array<float, 3> position{0, 0, 0};
  std::array<float, 4> rotation{0, 0, 0, 1};  // quaternion x, y, z, w
  std::array<float, 3> scale{1, 1, 1};
};

using ComponentTypes = std::tuple<Transform>;

}  // namespace cressim::scene
