// prepare() for rigid bodies: entities with RigidBody / Collider / Joint components flattened
// into per-env slices of bodies, colliders and joints (joints parent before child), with the
// mass properties and joint frames worked out from the authored poses.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "cressim/rigid.h"
#include "scene/layout_mapping.h"
#include "scene/world.h"

namespace cressim::physics {

struct RigidModel {
  std::vector<shader::BodyModel> bodies;
  // per body: inverse inertia and mass as authored, kinematic bodies included where they have a
  // mass and inertia (control.body_kinematic can then make them dynamic); 0 where they have none
  std::vector<shader::float4> dynamic_inertia;
  std::vector<uint32_t> kinematic;  // 1: authored kinematic (control.body_kinematic's start)
  std::vector<shader::float4> initial_positions, initial_rotations;
  std::vector<uint32_t> body_entity, body_env;
  std::vector<int64_t> entity_body;  // entity id -> body index, -1 when none
  std::vector<shader::ColliderModel> colliders;
  std::vector<shader::JointModel> joints;
  std::vector<shader::float4> joint_targets;
  std::vector<uint32_t> joint_entity;
  std::vector<int64_t> entity_joint;  // entity id -> joint index, -1 when none
  std::vector<std::array<uint32_t, 2>> filtered_pairs;
  std::vector<shader::EnvRigidRange> env_ranges;

  bool empty() const { return bodies.empty() && colliders.empty() && joints.empty(); }
};

RigidModel build_rigid_model(const scene::World& world, const scene::LayoutMapping& mapping);

}  // namespace cressim::physics
