// prepare() for particles the rasterizer draws from the physics buffers: soft-body surfaces
// (a vertex per surface particle) and strand tubes (a ring of vertices per particle) become meshes
// whose vertices the particle vertex pass writes each frame (particle_draw.h). Objects of one
// shape share a mesh, so every env's copy is one more instance of the same draw.
#pragma once
#include <cstdint>
#include <vector>

#include "physics/particle_model.h"
#include "render/render_model.h"

namespace cressim::render {

struct ParticleMeshes {
  std::vector<int32_t> object_mesh;     // per particle object: its mesh, -1 when not a mesh (fluids)
  std::vector<uint32_t> object_offset;  // RenderableData.maps.z: its first vertex within the mesh's
};

// Appends the generated vertices after the meshes' (zeros until the pass writes them), their
// recipes, and a mesh per distinct surface / strand shape.
ParticleMeshes add_particle_meshes(RenderModel& m, const physics::ParticleModel& particles);

}  // namespace cressim::render
