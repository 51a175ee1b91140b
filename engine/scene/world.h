// The authoring world: entities, each in one env, with components attached.
// Topology (entities, which components they have) is versioned so the runtime can tell when a
// new prepare() is needed; component values can change at any time.
#pragma once
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <tuple>
#include <type_traits>
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

  // Attaches a component. Replacing one the entity has: a Transform is a value change (as
  // set()); any other kind feeds the models prepare() built, so it is a topology change and the
  // next frame asks for prepare() again rather than keep the old value silently.
  template <class C>
  void add(EntityId e, const C& c) {
    check(e);
    auto& items = std::get<ComponentStore<C>>(stores_).items;
    const bool had = items.count(e) != 0;
    if (had && std::is_same_v<C, Transform>) return set(e, c);
    bump_topology(describe(e) + (had ? " replaced its " : " gained a ") + component_name<C>());
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
    if constexpr (std::is_same_v<C, Transform>) check_value(e, c);  // uploaded without another prepare()
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

  // Where a field was authored (e.g. "scene.yaml:12", set by the scene-file loader), for
  // errors. field: "" the entity, "Collider" a component, "Collider.shapes[0].size" a field.
  void set_source(EntityId e, const std::string& field, std::string where);
  // the most specific source known for `field` (its own, else its parent's ...), or ""
  std::string source_of(EntityId e, const std::string& field) const;

  uint64_t topology_version() const { return topology_version_; }
  const std::string& last_topology_change() const { return last_change_; }
  // Entities whose values changed since the last call (for incremental uploads).
  std::vector<EntityId> take_dirty() { return std::exchange(dirty_, {}); }

 private:
  void check(EntityId e) const;
  void check_value(EntityId e, const Transform& t) const;
  void bump_topology(std::string what) { ++topology_version_; last_change_ = std::move(what); }

  SceneLayout layout_;
  std::vector<uint32_t> env_;
  std::vector<std::string> names_;
  typename StoresOf<ComponentTypes>::type stores_;
  uint64_t topology_version_ = 0, value_version_ = 0;
  std::string last_change_;
  std::vector<EntityId> dirty_;
  std::unordered_map<EntityId, std::unordered_map<std::string, std::string>> sources_;
  std::vector<Mesh> meshes_;
  std::vector<Texture> textures_;
};

}  // namespace cressim::scene
