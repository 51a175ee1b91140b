#include "scene/layout_mapping.h"

#include <gtest/gtest.h>

using namespace cressim::scene;

TEST(LayoutMapping, RowsGroupedByEnvInCreationOrder) {
  World w(SceneLayout{3});
  for (uint32_t env : {2u, 0u, 2u, 1u, 0u}) w.create_entity(env);
  LayoutMapping m = build_layout_mapping(w);
  EXPECT_EQ(m.row_env, (std::vector<uint32_t>{0, 0, 1, 2, 2}));
  EXPECT_EQ(m.row_entity, (std::vector<uint32_t>{1, 4, 3, 0, 2}));
  EXPECT_EQ(m.env_offset, (std::vector<uint32_t>{0, 2, 3}));
  EXPECT_EQ(m.env_count, (std::vector<uint32_t>{2, 1, 2}));
  for (uint32_t e = 0; e < 5; ++e) EXPECT_EQ(m.row_entity[m.entity_row[e]], e);
  EXPECT_EQ(m.topology_version, w.topology_version());
}

TEST(LayoutMapping, AnEnvsRowsDoNotDependOnOtherEnvs) {
  World a(SceneLayout{2}), b(SceneLayout{2});
  a.create_entity(0);
  a.create_entity(0);
  b.create_entity(0);
  b.create_entity(1);
  b.create_entity(0);
  auto ma = build_layout_mapping(a), mb = build_layout_mapping(b);
  EXPECT_EQ(ma.env_count[0], mb.env_count[0]);
  EXPECT_EQ(ma.env_offset[0], mb.env_offset[0]);
}
