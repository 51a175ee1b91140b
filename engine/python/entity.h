// The Python handle to one entity; the world stays alive while handles exist.
#pragma once
#include <memory>

#include "scene/world.h"

namespace cressim::python {

struct Entity {
  std::shared_ptr<scene::World> world;
  scene::EntityId id;
};

}  // namespace cressim::python
