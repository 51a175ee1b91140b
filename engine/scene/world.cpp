#include "scene/world.h"

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

}  // namespace cressim::scene
