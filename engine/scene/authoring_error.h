// An authored value prepare() cannot use. The message names the entity, its env and the field
// ("entity 0 'liver' in env 1: SoftBody.mass must be positive, got -1"), led by where the field
// was written when the world came from a scene file ("scene.yaml:12: entity 0 ...").
#pragma once
#include <cstdint>
#include <stdexcept>
#include <string>

#include "scene/world.h"

namespace cressim::scene {

struct AuthoringError : std::invalid_argument {
  // field "": the leading "Component.field" of `problem` ("SoftBody.tets names particle 7 ...")
  AuthoringError(const World& world, EntityId entity, const std::string& problem, std::string field = "");

  EntityId entity;
  uint32_t env;
  std::string field;   // "SoftBody.tets", "Collider.shapes[0].size", or "" when none is named
  std::string source;  // "scene.yaml:12", or ""
};

}  // namespace cressim::scene
