// prepare() for the rasterizer: meshes packed into one vertex/index buffer, textures into one
// texel buffer, renderables, cameras and lights of every env, cameras grouped by resolution
// and products into layered targets, shadow maps grouped likewise, and the draw lists (one instanced draw
// per mesh and group).
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "cressim/render.h"
#include "physics/particle_model.h"
#include "scene/layout_mapping.h"
#include "scene/world.h"

namespace cressim::render {

struct MeshRange {
  uint32_t first_index = 0, index_count = 0;
  int32_t vertex_offset = 0;
  float radius = 0;  // of the bounding sphere about the mesh origin
  uint32_t vertex_count = 0;
  std::string positions_key;  // positions copied from this buffer every frame (scene::Mesh)
};

struct DrawCall {
  uint32_t mesh = 0;
  uint32_t first_instance = 0, instance_count = 0;
};

struct CameraGroup {
  uint32_t width = 0, height = 0, layers = 0;
  uint32_t products = scene::PRODUCT_ALL;  // scene::CameraProduct bits
  std::vector<DrawCall> draws;
};

// Shadow maps of consecutive envs with shadows, rendered as the layers of one depth target.
struct ShadowGroup {
  uint32_t first_map = 0, layers = 0;
  std::vector<DrawCall> draws;  // into shadow_instances
};

struct RenderModel {
  std::vector<shader::float4> vertex_positions, vertex_normals;
  std::vector<float> vertex_uvs;  // u v per vertex (0 where a mesh has none)
  std::vector<uint32_t> indices;
  std::vector<MeshRange> meshes;
  std::vector<shader::TextureInfo> textures;
  std::vector<uint32_t> texels;  // RGBA8 packed, every texture in turn
  std::vector<shader::RenderableData> renderables;
  std::vector<shader::CameraData> cameras;
  std::vector<uint32_t> camera_entity;
  std::vector<shader::LightData> lights;  // max_lights_per_env slots per env
  std::vector<shader::EnvLighting> env_lighting;  // per env
  std::vector<shader::float4> environment_maps;   // per IBL slot (a distinct map, intensity): texture, scale rgb
  std::vector<std::array<uint32_t, 2>> env_renderables;  // per env: first renderable, count
  std::vector<std::array<uint32_t, 2>> instances;  // (renderable, camera), by group then mesh
  std::vector<CameraGroup> groups;
  uint32_t shadow_resolution = 0, shadow_maps = 0;
  std::vector<std::array<uint32_t, 2>> shadow_instances;  // (renderable, layer), by group then mesh
  std::vector<ShadowGroup> shadow_groups;
  // particles drawn from the physics buffers (particle_geometry.h, particle_draw.h)
  uint32_t particle_vertex_base = 0;               // the generated vertices follow the meshes'
  std::vector<shader::uint4> particle_vertices;    // how each is made (PARTICLE_VERTEX_*)
  std::vector<uint32_t> particle_adjacency;        // each surface vertex's triangles
  std::vector<shader::uint4> particle_triangles;   // surface triangles (global particle ids)
  std::vector<shader::RenderableData> fluid_looks;  // per env: its fluid (ids.y 1) look, radius in material.z
  bool has_fluid = false;

  bool empty() const { return cameras.empty(); }
};

RenderModel build_render_model(const scene::World& world, const scene::LayoutMapping& mapping, uint32_t max_layers,
                               const physics::ParticleModel& particles);

}  // namespace cressim::render
