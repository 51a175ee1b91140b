#include "render/render_model.h"

#include "render/mip_chain.h"
#include "render/particle_geometry.h"
#include "scene/authoring_error.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <cstdlib>
#include <cstring>
#include <stdexcept>

namespace cressim::render {
namespace {

[[noreturn]] void fail(const scene::World& w, scene::EntityId e, const std::string& what) {
  throw scene::AuthoringError(w, e, what);
}

// which textures hold normals (linear values, averaged as such in their mip levels); one used
// both ways is refused, naming the entity that uses it the second way
std::vector<bool> normal_map_textures(const scene::World& world, const scene::LayoutMapping& mapping) {
  const size_t n = world.textures().size();
  std::vector<int8_t> use(n, 0);  // 0 unused, 1 colour, 2 normals
  auto mark = [&](scene::EntityId e, int32_t texture, int8_t how, const char* field) {
    if (texture < -1 || texture >= int32_t(n))
      fail(world, e, std::string(field) + " " + std::to_string(texture) + " is not a texture of the world (" +
                         std::to_string(n) + " textures; world.add_texture returns the index)");
    if (texture < 0) return;
    if (use[texture] != 0 && use[texture] != how)
      fail(world, e, std::string(field) + " " + std::to_string(texture) + " is also used " +
                         (how == 2 ? "as a colour texture" : "as a normal map") +
                         ": normal maps hold linear values, colours sRGB; add the image twice");
    use[texture] = how;
  };
  for (uint32_t row = 0; row < mapping.row_entity.size(); ++row) {
    const scene::EntityId e = mapping.row_entity[row];
    if (world.has<scene::Renderable>(e)) {
      const auto& r = world.get<scene::Renderable>(e);
      mark(e, r.texture, 1, "Renderable.texture");
      mark(e, r.normal_map, 2, "Renderable.normal_map");
    }
    if (world.has<scene::EnvironmentLight>(e)) mark(e, world.get<scene::EnvironmentLight>(e).map, 1, "EnvironmentLight.map");
  }
  std::vector<bool> normals(n);
  for (size_t i = 0; i < n; ++i) normals[i] = use[i] == 2;
  return normals;
}

}  // namespace

RenderModel build_render_model(const scene::World& world, const scene::LayoutMapping& mapping, uint32_t max_layers,
                               const physics::ParticleModel& particles) {
  // CRESSIM_MAX_LAYERS lowers the layers per target (tests split small batches into groups)
  if (const char* v = std::getenv("CRESSIM_MAX_LAYERS"); v && std::atoi(v) > 0)
    max_layers = std::min(max_layers, uint32_t(std::atoi(v)));
  RenderModel m;
  for (const auto& mesh : world.meshes()) {
    MeshRange r{uint32_t(m.indices.size()), uint32_t(mesh.indices.size()), int32_t(m.vertex_positions.size()), 0,
                mesh.vertex_count(), mesh.positions_key};
    for (uint32_t v = 0; v < mesh.vertex_count(); ++v) {
      const float x = mesh.positions[3 * v], y = mesh.positions[3 * v + 1], z = mesh.positions[3 * v + 2];
      r.radius = std::max(r.radius, std::sqrt(x * x + y * y + z * z));
      m.vertex_positions.push_back({x, y, z, 1});
      m.vertex_normals.push_back({mesh.normals[3 * v], mesh.normals[3 * v + 1], mesh.normals[3 * v + 2], 0});
    }
    if (mesh.uvs.empty()) m.vertex_uvs.resize(m.vertex_uvs.size() + 2 * mesh.vertex_count(), 0.f);
    else m.vertex_uvs.insert(m.vertex_uvs.end(), mesh.uvs.begin(), mesh.uvs.end());
    m.indices.insert(m.indices.end(), mesh.indices.begin(), mesh.indices.end());
    m.meshes.push_back(r);
  }
  const ParticleMeshes particle_meshes = add_particle_meshes(m, particles);
  std::map<scene::EntityId, std::vector<uint32_t>> entity_objects;
  for (uint32_t o = 0; o < particles.objects.size(); ++o) entity_objects[particles.object_entity[o]].push_back(o);
  const std::vector<bool> normal_maps = normal_map_textures(world, mapping);
  for (size_t i = 0; i < world.textures().size(); ++i) {
    const auto& t = world.textures()[i];
    m.textures.push_back({{uint32_t(m.texels.size()), t.width, t.height, 0}});
    const size_t first = m.texels.size();
    m.texels.resize(first + size_t(t.width) * t.height);
    std::memcpy(m.texels.data() + first, t.rgba.data(), t.rgba.size());  // little-endian RGBA8 words
    m.textures.back().extent.w = append_mip_chain(m.texels, t.width, t.height, !normal_maps[i]);
  }
  const auto& layout = world.layout();
  const uint32_t slots = layout.max_lights_per_env;
  m.lights.assign(size_t(mapping.num_envs) * slots, shader::LightData{});
  m.env_lighting.assign(mapping.num_envs, shader::EnvLighting{});
  m.fluid_looks.assign(mapping.num_envs, shader::RenderableData{});
  std::vector<std::vector<uint32_t>> env_renderables(mapping.num_envs), env_cameras(mapping.num_envs);
  std::vector<uint32_t> shadow_envs;
  std::map<std::array<float, 2>, uint32_t> map_slots;  // (texture, intensity) -> IBL slot
  std::map<std::array<uint32_t, 3>, std::vector<uint32_t>> by_config;  // (width, height, products)
  for (uint32_t env = 0; env < mapping.num_envs; ++env) {
    uint32_t lights = 0;
    float ambient = 0.2f;
    bool environment = false;
    shader::EnvLighting& lighting = m.env_lighting[env];
    lighting.ids = {env * slots, slots, 0, shader::RENDER_NO_ROW};
    for (uint32_t row = mapping.env_offset[env]; row < mapping.env_offset[env] + mapping.env_count[env]; ++row) {
      const scene::EntityId e = mapping.row_entity[row];
      if (world.has<scene::EnvironmentLight>(e)) {
        if (environment) fail(world, e, "env " + std::to_string(env) + " has a second EnvironmentLight");
        const auto& a = world.get<scene::EnvironmentLight>(e);
        lighting.sky = {a.sky[0] * a.intensity, a.sky[1] * a.intensity, a.sky[2] * a.intensity, 0};
        lighting.ground = {a.ground[0] * a.intensity, a.ground[1] * a.intensity, a.ground[2] * a.intensity, 0};
        environment = true;
        if (a.map >= 0) {  // envs with the same map and intensity share one filtered slot
          auto [it, added] = map_slots.try_emplace({float(a.map), a.intensity}, uint32_t(m.environment_maps.size()));
          if (added) m.environment_maps.push_back({float(a.map), a.intensity, a.intensity, a.intensity});
          lighting.map = {uint32_t(a.map) + 1, it->second, 0, 0};
          lighting.map_scale = {a.intensity, a.intensity, a.intensity, 0};
        }
      }
      if (world.has<scene::Renderable>(e)) {
        const auto& r = world.get<scene::Renderable>(e);
        if (r.mesh >= m.meshes.size())
          fail(world, e, "Renderable.mesh " + std::to_string(r.mesh) + " is not a mesh of the world (" +
                             std::to_string(m.meshes.size()) + " meshes; world.add_mesh returns the index)");
        env_renderables[env].push_back(uint32_t(m.renderables.size()));
        const uint32_t flat = m.meshes[r.mesh].positions_key.empty() ? 0u : shader::RENDER_FLAT_NORMALS;
        m.renderables.push_back({{row, r.mesh, r.segmentation_id ? r.segmentation_id : e + 1, env},
                                 {r.color[0], r.color[1], r.color[2], r.color[3]},
                                 {r.metallic, r.roughness, 0, r.normal_scale},
                                 {uint32_t(r.texture + 1), flat | uint32_t(r.normal_map + 1) << shader::RENDER_NORMAL_MAP_SHIFT,
                                  0, 0}});
        if (env_renderables[env].size() > layout.max_renderables_per_env)
          fail(world, e, "env " + std::to_string(env) + " has more renderables than SceneLayout.max_renderables_per_env = " +
                             std::to_string(layout.max_renderables_per_env));
      }
      if (auto it = entity_objects.find(e); it != entity_objects.end()) {
        // particle objects: their Material (or a default look per kind), segmentation entity id + 1
        for (uint32_t o : it->second) {
          const auto& obj = particles.objects[o];
          const uint32_t kind = obj.range.w;
          scene::Material look;
          look.color = kind == shader::PARTICLE_FLUID    ? std::array<float, 4>{0.35f, 0.01f, 0.01f, 1}  // blood
                       : kind == shader::PARTICLE_STRAND ? std::array<float, 4>{0.75f, 0.75f, 0.7f, 1}
                                                         : std::array<float, 4>{0.75f, 0.35f, 0.3f, 1};  // tissue
          if (kind == shader::PARTICLE_FLUID) look.roughness = 0.15f;
          if (world.has<scene::Material>(e)) look = world.get<scene::Material>(e);
          const shader::RenderableData d{{row, 0, look.segmentation_id ? look.segmentation_id : e + 1, env},
                                         {look.color[0], look.color[1], look.color[2], look.color[3]},
                                         {look.metallic, look.roughness, obj.material.x, 0},
                                         {0, 0, particle_meshes.object_offset[o], shader::RENDER_WORLD_VERTICES}};
          if (kind == shader::PARTICLE_FLUID) {
            if (m.fluid_looks[env].ids.y == 0) m.fluid_looks[env] = d;  // an env's fluids look like its first
            m.fluid_looks[env].ids.y = 1;
            m.has_fluid = true;
            continue;
          }
          if (particle_meshes.object_mesh[o] < 0) continue;
          env_renderables[env].push_back(uint32_t(m.renderables.size()));
          m.renderables.push_back(d);
          m.renderables.back().ids.y = uint32_t(particle_meshes.object_mesh[o]);
          if (env_renderables[env].size() > layout.max_renderables_per_env)
            fail(world, e, "env " + std::to_string(env) + " has more renderables (particle objects count) than "
                           "SceneLayout.max_renderables_per_env = " + std::to_string(layout.max_renderables_per_env));
        }
      }
      if (world.has<scene::Camera>(e)) {
        const auto& c = world.get<scene::Camera>(e);
        const float f = c.fx > 0 ? c.fx : 0.5f * float(c.height) / std::tan(0.5f * c.fov_y * std::numbers::pi_v<float> / 180);
        shader::CameraData d{{f, c.fy > 0 ? c.fy : f, c.cx >= 0 ? c.cx : 0.5f * float(c.width),
                              c.cy >= 0 ? c.cy : 0.5f * float(c.height)},
                             {c.near, c.far, float(c.width), float(c.height)},
                             {row, env, 0, 0}};
        env_cameras[env].push_back(uint32_t(m.cameras.size()));
        by_config[{c.width, c.height, c.products}].push_back(uint32_t(m.cameras.size()));
        m.cameras.push_back(d);
        m.camera_entity.push_back(e);
        if (env_cameras[env].size() > layout.max_cameras_per_env)
          fail(world, e, "env " + std::to_string(env) + " has more cameras than SceneLayout.max_cameras_per_env = " +
                             std::to_string(layout.max_cameras_per_env));
      }
      if (world.has<scene::Light>(e)) {
        if (++lights > slots)
          fail(world, e, "env " + std::to_string(env) + " has more lights than SceneLayout.max_lights_per_env = " +
                             std::to_string(slots));
        const auto& l = world.get<scene::Light>(e);
        if (lights == 1) ambient = l.ambient;
        const float deg = std::numbers::pi_v<float> / 180;
        m.lights[size_t(env) * slots + lights - 1] = {
            {row, uint32_t(l.kind), 0, 0},
            {l.color[0] * l.intensity, l.color[1] * l.intensity, l.color[2] * l.intensity, l.range},
            {std::cos(l.inner_angle * deg), std::cos(l.outer_angle * deg), 0, 0},
            {0, 0, 1, 0}};
        if (l.shadows && l.kind == scene::LightKind::DIRECTIONAL && lighting.ids.z == 0) {
          lighting.ids.z = uint32_t(shadow_envs.size()) + 1;
          lighting.ids.w = row;
          lighting.shadow = {l.shadow_extent, 4 * l.shadow_extent + 10, 0, 0};
          m.shadow_resolution = std::max(m.shadow_resolution, l.shadow_resolution);
          shadow_envs.push_back(env);
        }
      }
    }
    if (lights == 0)  // a default light from above
      m.lights[size_t(env) * slots] = {{shader::RENDER_NO_ROW, shader::LIGHT_DIRECTIONAL, 0, 0},
                                       {1, 1, 1, 0}, {1, 0, 0, 0}, {0.3f, 0.2f, -1.0f, 0}};
    if (!environment) {
      lighting.sky = {ambient, ambient, ambient, 0};
      lighting.ground = lighting.sky;
    }
  }
  for (auto& l : m.env_lighting) l.shadow.z = float(m.shadow_resolution);
  for (const auto& r : env_renderables)  // renderables are stored env by env
    m.env_renderables.push_back({r.empty() ? 0 : r.front(), uint32_t(r.size())});
  m.shadow_maps = uint32_t(shadow_envs.size());
  // shadow maps of at most max_layers envs a group; instances by group, then mesh
  for (uint32_t first = 0; first < shadow_envs.size(); first += max_layers) {
    ShadowGroup g{first, std::min<uint32_t>(max_layers, uint32_t(shadow_envs.size()) - first), {}};
    std::vector<std::vector<std::array<uint32_t, 2>>> per_mesh(m.meshes.size());
    for (uint32_t layer = 0; layer < g.layers; ++layer)
      for (uint32_t r : env_renderables[shadow_envs[first + layer]]) per_mesh[m.renderables[r].ids.y].push_back({r, layer});
    for (uint32_t mesh = 0; mesh < per_mesh.size(); ++mesh) {
      if (per_mesh[mesh].empty()) continue;
      g.draws.push_back({mesh, uint32_t(m.shadow_instances.size()), uint32_t(per_mesh[mesh].size())});
      m.shadow_instances.insert(m.shadow_instances.end(), per_mesh[mesh].begin(), per_mesh[mesh].end());
    }
    m.shadow_groups.push_back(std::move(g));
  }
  // groups: cameras of one resolution and products, at most max_layers each; instances by group, then mesh
  for (auto& [config, cams] : by_config) {
    for (size_t first = 0; first < cams.size(); first += max_layers) {
      CameraGroup g{config[0], config[1], uint32_t(std::min<size_t>(max_layers, cams.size() - first)), config[2], {}};
      const uint32_t group = uint32_t(m.groups.size());
      std::vector<std::vector<std::array<uint32_t, 2>>> per_mesh(m.meshes.size());
      for (uint32_t layer = 0; layer < g.layers; ++layer) {
        const uint32_t cam = cams[first + layer];
        m.cameras[cam].ids.z = group;
        m.cameras[cam].ids.w = layer;
        for (uint32_t r : env_renderables[m.cameras[cam].ids.y]) per_mesh[m.renderables[r].ids.y].push_back({r, cam});
      }
      for (uint32_t mesh = 0; mesh < per_mesh.size(); ++mesh) {
        if (per_mesh[mesh].empty()) continue;
        g.draws.push_back({mesh, uint32_t(m.instances.size()), uint32_t(per_mesh[mesh].size())});
        m.instances.insert(m.instances.end(), per_mesh[mesh].begin(), per_mesh[mesh].end());
      }
      m.groups.push_back(std::move(g));
    }
  }
  return m;
}

}  // namespace cressim::render
