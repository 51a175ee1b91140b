// The authoring world: entities, each in one env, with components attached.
// Topology (entities, which components they have) is versioned so the runtime can tell when a
// new prepare() is needed; component values can change at any time.
#pragma once
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <tuple>
#include <unordered_map>
#include <utility>
#include <vector>

#include "scene/components.h"
#include "scene/scene_layout.h"

namespace cressim::scene {

using EntityId = uint32_t;

template <class C>
struct ComponentStore {
  std::unordered_map<EntityId, C> items;
};

template <class Tuple>
struct StoresOf;
template <class... Cs>
struct StoresOf<std::tuple<Cs...>> {
  using type = std::tuple<ComponentStore<Cs>...>;
};

class World {
 public:
  explicit World(SceneLayout layout);

  const SceneLayout& layout() const { return layout_; }
  EntityId create_entity(uint32_t env, const std::string& name = "");
  size_t entity_count() const { return env_.size(); }
  uint32_t env_of(EntityId e) const { check(e); return env_[e]; }
  const std::string& name_of(EntityId e) const { check(e); return names_[e]; }
  std::string describe(EntityId e) const;  // "entity 12 'cart' in env 3", for messages

  template <class C>
  void add(EntityId e, const C& c) {
    check(e);
    auto& items = std::get<ComponentStore<C>>(stores_).items;
    if (!items.count(e)) bump_topology(describe(e) + " gained a component");
    items[e] = c;
    ++value_version_;
  }
  template <class C>
  bool has(EntityId e) const { check(e); return std::get<ComponentStore<C>>(stores_).items.count(e) != 0; }
  template <class C>
  const C& get(EntityId e) const {
    check(e);
    auto& items = std::get<ComponentStore<C>>(stores_).items;
    auto it = items.find(e);
    if (it == items.end()) throw std::out_of_range(describe(e) + " has no such component");
    return it->second;
  }
  // Changes a value only (never topology); the runtime uploads it before the next frame.
  template <class C>
  void set(EntityId e, const C& c) {
    check(e);
    auto& items = std::get<ComponentStore<C>>(stores_).items;
    auto it = items.find(e);
    if (it == items.end()) throw std::out_of_range(describe(e) + " has no such component; use add()");
    it->second = c;
    ++value_version_;
    dirty_.push_back(e);
  }

  // shared meshes: the index goes into Renderable.mesh
  uint32_t add_mesh(Mesh mesh);
  const std::vector<Mesh>& meshes() const { return meshes_; }
  // shared textures: the index goes into Renderable.texture
  uint32_t add_texture(Texture texture);
  const std::vector<Texture>& textures() const { return textures_; }

  uint64_t topology_version() const { return topology_version_; }
  const std::string& last_topology_change() const { return last_change_; }
  // Entities whose values changed since the last call (for incremental uploads).
  std::vector<EntityId> take_dirty() { return std::exchange(dirty_, {}); }

 private:
  void check(EntityId e) const;
  void bump_topology(std::string what) { ++topology_version_; last_change_ = std::move(what); }

  SceneLayout layout_;
  std::vector<uint32_t> env_;
  std::vector<std::string> names_;
  typename StoresOf<ComponentTypes>::type stores_;
  uint64_t topology_version_ = 0, value_version_ = 0;
  std::string last_change_;
  std::vector<EntityId> dirty_;
  std::vector<Mesh> meshes_;
  std::vector<Texture> textures_;
};

}  // namespace cressim::scene
