#include "render/render_model.h"

#include <cmath>
#include <map>
#include <numbers>
#include <stdexcept>

namespace cressim::render {
namespace {

[[noreturn]] void fail(const scene::World& w, scene::EntityId e, const std::string& what) {
  throw std::invalid_argument(w.describe(e) + ": " + what);
}

shader::float4 rotate_z(const scene::Quat& q) {  // the entity's +z in world
  const float x = q[0], y = q[1], z = q[2], w = q[3];
  return {2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y), 0};
}

}  // namespace

RenderModel build_render_model(const scene::World& world, const scene::LayoutMapping& mapping, uint32_t max_layers) {
  RenderModel m;
  for (const auto& mesh : world.meshes()) {
    MeshRange r{uint32_t(m.indices.size()), uint32_t(mesh.indices.size()), int32_t(m.vertex_positions.size())};
    for (uint32_t v = 0; v < mesh.vertex_count(); ++v) {
      m.vertex_positions.push_back({mesh.positions[3 * v], mesh.positions[3 * v + 1], mesh.positions[3 * v + 2], 1});
      m.vertex_normals.push_back({mesh.normals[3 * v], mesh.normals[3 * v + 1], mesh.normals[3 * v + 2], 0});
    }
    m.indices.insert(m.indices.end(), mesh.indices.begin(), mesh.indices.end());
    m.meshes.push_back(r);
  }
  const auto& layout = world.layout();
  m.lights.assign(mapping.num_envs, {{0.3f, 0.2f, -1.0f, 0.2f}, {1, 1, 1, 0}});  // default: from above
  std::vector<std::vector<uint32_t>> env_renderables(mapping.num_envs), env_cameras(mapping.num_envs);
  std::map<std::pair<uint32_t, uint32_t>, std::vector<uint32_t>> by_resolution;
  for (uint32_t env = 0; env < mapping.num_envs; ++env) {
    bool lit = false;
    uint32_t lights = 0;
    for (uint32_t row = mapping.env_offset[env]; row < mapping.env_offset[env] + mapping.env_count[env]; ++row) {
      const scene::EntityId e = mapping.row_entity[row];
      if (world.has<scene::Renderable>(e)) {
        const auto& r = world.get<scene::Renderable>(e);
        if (r.mesh >= m.meshes.size())
          fail(world, e, "Renderable.mesh " + std::to_string(r.mesh) + " is not a mesh of the world (" +
                             std::to_string(m.meshes.size()) + " meshes; world.add_mesh returns the index)");
        env_renderables[env].push_back(uint32_t(m.renderables.size()));
        m.renderables.push_back({{row, r.mesh, r.segmentation_id ? r.segmentation_id : e + 1, env},
                                 {r.color[0], r.color[1], r.color[2], r.color[3]},
                                 {r.metallic, r.roughness, 0, 0}});
        if (env_renderables[env].size() > layout.max_renderables_per_env)
          fail(world, e, "env " + std::to_string(env) + " has more renderables than SceneLayout.max_renderables_per_env = " +
                             std::to_string(layout.max_renderables_per_env));
      }
      if (world.has<scene::Camera>(e)) {
        const auto& c = world.get<scene::Camera>(e);
        if (c.width == 0 || c.height == 0 || !(c.near > 0) || !(c.far > c.near))
          fail(world, e, "Camera needs width, height > 0 and 0 < near < far");
        const float f = c.fx > 0 ? c.fx : 0.5f * float(c.height) / std::tan(0.5f * c.fov_y * std::numbers::pi_v<float> / 180);
        shader::CameraData d{{f, c.fy > 0 ? c.fy : f, c.cx >= 0 ? c.cx : 0.5f * float(c.width),
                              c.cy >= 0 ? c.cy : 0.5f * float(c.height)},
                             {c.near, c.far, float(c.width), float(c.height)},
                             {row, env, 0, 0}};
        env_cameras[env].push_back(uint32_t(m.cameras.size()));
        by_resolution[{c.width, c.height}].push_back(uint32_t(m.cameras.size()));
        m.cameras.push_back(d);
        m.camera_entity.push_back(e);
        if (env_cameras[env].size() > layout.max_cameras_per_env)
          fail(world, e, "env " + std::to_string(env) + " has more cameras than SceneLayout.max_cameras_per_env = " +
                             std::to_string(layout.max_cameras_per_env));
      }
      if (world.has<scene::Light>(e)) {
        if (++lights > layout.max_lights_per_env)
          fail(world, e, "env " + std::to_string(env) + " has more lights than SceneLayout.max_lights_per_env = " +
                             std::to_string(layout.max_lights_per_env));
        if (lit) continue;  // one directional light per env is shaded
        const auto& l = world.get<scene::Light>(e);
        const auto& q = world.has<scene::Transform>(e) ? world.get<scene::Transform>(e).rotation : scene::Quat{0, 0, 0, 1};
        shader::float4 d = rotate_z(q);
        d.w = l.ambient;
        m.lights[env] = {d, {l.color[0] * l.intensity, l.color[1] * l.intensity, l.color[2] * l.intensity, 0}};
        lit = true;
      }
    }
  }
  // groups: cameras of one resolution, at most max_layers each; instances by group, then mesh
  for (auto& [resolution, cams] : by_resolution) {
    for (size_t first = 0; first < cams.size(); first += max_layers) {
      CameraGroup g{resolution.first, resolution.second, uint32_t(std::min<size_t>(max_layers, cams.size() - first)), {}};
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
