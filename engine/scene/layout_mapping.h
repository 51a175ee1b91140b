// prepare(): the authored world flattened into GPU rows grouped by env, and the maps that let
// a user (or a custom pass) interpret the packed buffers.
#pragma once
#include <cstdint>
#include <vector>

#include "scene/world.h"

namespace cressim::scene {

struct LayoutMapping {
  uint32_t num_envs = 0;
  // one row per entity, envs contiguous in ascending order, creation order within an env
  std::vector<uint32_t> row_entity;  // row -> entity id
  std::vector<uint32_t> row_env;     // row -> env index
  std::vector<uint32_t> entity_row;  // entity id -> row
  std::vector<uint32_t> env_offset;  // env -> first row
  std::vector<uint32_t> env_count;   // env -> number of rows
  uint64_t topology_version = 0;     // of the world it was built from

  size_t rows() const { return row_entity.size(); }
};

LayoutMapping build_layout_mapping(const World& world);

}  // namespace cressim::scene
