#include "scene/world.h"

#include "scene/validate.h"

namespace cressim::scene {

World::World(SceneLayout layout) : layout_(layout) { layout_.validate(); }

EntityId World::create_entity(uint32_t env, const std::string& name) {
  if (env >= layout_.num_envs)
    throw std::out_of_range("create_entity: env " + std::to_string(env) + " is out of range (the layout has " +
                            std::to_string(layout_.num_envs) + " envs)");
  EntityId e = EntityId(env_.size());
  env_.push_back(env);
  names_.push_back(name);
  bump_topology("created " + describe(e));
  return e;
}

uint32_t World::add_mesh(Mesh mesh) {
  const size_t n = mesh.positions.size();
  if (n == 0 || n % 3 || mesh.normals.size() != n || mesh.indices.size() % 3)
    throw std::invalid_argument("add_mesh: positions and normals need 3 numbers per vertex (the same count), "
                                "indices 3 per triangle");
  for (uint32_t i : mesh.indices)
    if (i >= mesh.vertex_count())
      throw std::invalid_argument("add_mesh: index " + std::to_string(i) + " beyond the " +
                                  std::to_string(mesh.vertex_count()) + " vertices");
  if (!mesh.uvs.empty() && mesh.uvs.size() != 2 * size_t(mesh.vertex_count()))
    throw std::invalid_argument("add_mesh: uvs need 2 numbers per vertex (" + std::to_string(mesh.vertex_count()) +
                                " vertices, " + std::to_string(mesh.uvs.size()) + " numbers)");
  meshes_.push_back(std::move(mesh));
  bump_topology("added mesh " + std::to_string(meshes_.size() - 1));
  return uint32_t(meshes_.size() - 1);
}

uint32_t World::add_texture(Texture texture) {
  if (texture.width == 0 || texture.height == 0 || texture.rgba.size() != size_t(texture.width) * texture.height * 4)
    throw std::invalid_argument("add_texture: needs width, height > 0 and 4 bytes per texel (" +
                                std::to_string(texture.width) + "x" + std::to_string(texture.height) + ", " +
                                std::to_string(texture.rgba.size()) + " bytes)");
  textures_.push_back(std::move(texture));
  bump_topology("added texture " + std::to_string(textures_.size() - 1));
  return uint32_t(textures_.size() - 1);
}

void World::set_source(EntityId e, const std::string& field, std::string where) {
  check(e);
  sources_[e][field] = std::move(where);
}

std::string World::source_of(EntityId e, const std::string& field) const {
  auto it = sources_.find(e);
  if (it == sources_.end()) return "";
  // "Collider.shapes[0].size" -> "Collider.shapes[0]" -> "Collider.shapes" -> "Collider" -> ""
  for (std::string f = field;;) {
    if (auto s = it->second.find(f); s != it->second.end()) return s->second;
    if (f.empty()) return "";
    const size_t cut = f.find_last_of(".[");
    f.resize(cut == std::string::npos ? 0 : cut);
  }
}

std::string World::describe(EntityId e) const {
  std::string s = "entity " + std::to_string(e);
  if (e < names_.size() && !names_[e].empty()) s += " '" + names_[e] + "'";
  if (e < env_.size()) s += " in env " + std::to_string(env_[e]);
  return s;
}

void World::check(EntityId e) const {
  if (e >= env_.size())
    throw std::out_of_range("entity " + std::to_string(e) + " does not exist (the world has " +
                            std::to_string(env_.size()) + " entities)");
}

void World::check_value(EntityId e, const Transform& t) const { validate_transform(*this, e, t); }

}  // namespace cressim::scene
