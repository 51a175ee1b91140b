#include "scene/layout_mapping.h"

namespace cressim::scene {

LayoutMapping build_layout_mapping(const World& world) {
  LayoutMapping m;
  m.num_envs = world.layout().num_envs;
  m.topology_version = world.topology_version();
  const uint32_t n = uint32_t(world.entity_count());
  m.env_count.assign(m.num_envs, 0);
  for (EntityId e = 0; e < n; ++e) ++m.env_count[world.env_of(e)];
  // counting sort by env keeps creation order inside each env
  m.env_offset.assign(m.num_envs, 0);
  for (uint32_t i = 1; i < m.num_envs; ++i) m.env_offset[i] = m.env_offset[i - 1] + m.env_count[i - 1];
  std::vector<uint32_t> cursor = m.env_offset;
  m.row_entity.resize(n);
  m.row_env.resize(n);
  m.entity_row.resize(n);
  for (EntityId e = 0; e < n; ++e) {
    const uint32_t env = world.env_of(e), row = cursor[env]++;
    m.row_entity[row] = e;
    m.row_env[row] = env;
    m.entity_row[e] = row;
  }
  return m;
}

}  // namespace cressim::scene
