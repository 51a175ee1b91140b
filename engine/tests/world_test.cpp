#include "scene/world.h"

#include <gtest/gtest.h>

using namespace cressim::scene;

TEST(World, TopologyVersionCountsStructureNotValues) {
  World w(SceneLayout{2});
  auto v0 = w.topology_version();
  EntityId e = w.create_entity(1, "probe");
  EXPECT_GT(w.topology_version(), v0);
  auto v1 = w.topology_version();
  w.add(e, Transform{});
  EXPECT_GT(w.topology_version(), v1);
  auto v2 = w.topology_version();
  w.set(e, Transform{{1, 2, 3}});
  EXPECT_EQ(w.topology_version(), v2);
  EXPECT_EQ(w.get<Transform>(e).position[2], 3.f);
  EXPECT_EQ(w.take_dirty(), std::vector<EntityId>{e});
  EXPECT_TRUE(w.take_dirty().empty());
  EXPECT_EQ(w.last_topology_change(), "entity 0 'probe' in env 1 gained a Transform");
}

TEST(World, ErrorsNameTheEntityAndEnv) {
  World w(SceneLayout{2});
  EXPECT_THROW(w.create_entity(2), std::out_of_range);
  EntityId e = w.create_entity(0);
  EXPECT_THROW(w.get<Transform>(e), std::out_of_range);
  EXPECT_THROW(w.set(e, Transform{}), std::out_of_range);
  EXPECT_THROW(w.env_of(99), std::out_of_range);
}
