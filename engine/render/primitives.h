// Meshes of the primitive shapes (the same shapes as the colliders), for Renderable.mesh.
#pragma once
#include <array>

#include "scene/components.h"

namespace cressim::render {

scene::Mesh box_mesh(std::array<float, 3> half_extents);
scene::Mesh sphere_mesh(float radius, uint32_t rings = 24, uint32_t segments = 48);
scene::Mesh capsule_mesh(float radius, float half_height, uint32_t rings = 12, uint32_t segments = 32);  // along z
scene::Mesh plane_mesh(float half_size);  // in xy, normal +z

}  // namespace cressim::render
