// prepare()'s first step: every authored field of every component checked (finite, in range)
// before any model is built from it, so a bad value is an AuthoringError naming the entity, its
// env and the field, not a NaN that resets the env every frame or a value quietly replaced.
// One function per component kind in validate.cpp; docs/physics.md lists the rules. Checks that
// need the models (indices into particle arrays, joint bodies, layout capacities) stay with them.
#pragma once
#include "scene/world.h"

namespace cressim::scene {

void validate_world(const World& world);
// a Transform set while running (entity.transform = ...), checked as it is set
void validate_transform(const World& world, EntityId entity, const Transform& t);

}  // namespace cressim::scene
