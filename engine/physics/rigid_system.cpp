#include "physics/rigid_system.h"

#include <algorithm>
#include <cstring>

#include "gpu/context.h"

namespace cressim::physics {
namespace {

using compute::DType;

template <class T>
std::shared_ptr<compute::TypedBuffer> make(std::shared_ptr<gpu::Context> ctx, BufferMap& into, const std::string& key,
                                           const std::vector<T>& data, std::vector<int64_t> shape, DType dtype,
                                           bool read_only, uint64_t generation, bool exportable = false) {
  return compute::make_keyed_buffer(std::move(ctx), into, key, data, std::move(shape), dtype, read_only, generation,
                                    exportable);
}

}  // namespace

RigidSystem::RigidSystem(std::shared_ptr<gpu::Context> ctx, RigidModel model, const PhysicsSettings& settings,
                         uint64_t generation, BufferMap& internal, BufferMap& control, const BufferMap& scene)
    : model_(std::move(model)), max_contacts_(settings.max_contacts_per_env) {
  const auto nb = int64_t(model_.bodies.size()), nc = int64_t(model_.colliders.size()),
             nj = int64_t(model_.joints.size()), ne = int64_t(model_.env_ranges.size());
  const bool exportable = ctx->external_memory_fd && !ctx->unified_memory;
  using shader::float4;
  const std::vector<float4> zeros_b(size_t(nb), float4{0, 0, 0, 0}), zeros_j(size_t(nj), float4{0, 0, 0, 0});
  auto in = [&](const std::string& k, const auto& data, std::vector<int64_t> shape, DType t, bool exp = false) {
    return make(ctx, internal, k, data, std::move(shape), t, true, generation, exp);
  };
  auto ctl = [&](const std::string& k, const auto& data, std::vector<int64_t> shape, DType t) {
    return make(ctx, control, k, data, std::move(shape), t, false, generation, exportable);
  };
  // state (read-only to custom passes; written by the solver and resets)
  in("rigid.positions", model_.initial_positions, {nb, 4}, DType::FLOAT32, exportable);
  in("rigid.rotations", model_.initial_rotations, {nb, 4}, DType::FLOAT32, exportable);
  in("rigid.linear_velocities", zeros_b, {nb, 4}, DType::FLOAT32, exportable);
  in("rigid.angular_velocities", zeros_b, {nb, 4}, DType::FLOAT32, exportable);
  in("rigid.initial_positions", model_.initial_positions, {nb, 4}, DType::FLOAT32);
  in("rigid.initial_rotations", model_.initial_rotations, {nb, 4}, DType::FLOAT32);
  in("rigid.body_entity", model_.body_entity, {nb}, DType::UINT32);
  in("rigid.body_env", model_.body_env, {nb}, DType::UINT32);
  in("rigid.bodies", model_.bodies, {nb, int64_t(sizeof(shader::BodyModel) / 4)}, DType::UINT32);
  in("rigid.dynamic_inertia", model_.dynamic_inertia, {nb, 4}, DType::FLOAT32);
  in("rigid.colliders", model_.colliders, {nc, int64_t(sizeof(shader::ColliderModel) / 4)}, DType::UINT32);
  in("rigid.env_ranges", model_.env_ranges, {ne, int64_t(sizeof(shader::EnvRigidRange) / 4)}, DType::UINT32);
  in("joint.model", model_.joints, {nj, int64_t(sizeof(shader::JointModel) / 4)}, DType::UINT32);
  in("joint.entity", model_.joint_entity, {nj}, DType::UINT32);
  std::vector<uint32_t> pairs;
  for (auto& p : model_.filtered_pairs) pairs.insert(pairs.end(), p.begin(), p.end());
  in("rigid.filtered_pairs", pairs, {int64_t(model_.filtered_pairs.size()), 2}, DType::UINT32);
  in("joint.positions", std::vector<float>(size_t(nj), 0.f), {nj}, DType::FLOAT32, exportable);
  in("joint.velocities", std::vector<float>(size_t(nj), 0.f), {nj}, DType::FLOAT32, exportable);
  in("env.health", std::vector<uint32_t>(size_t(ne), 0u), {ne}, DType::UINT32, exportable);
  // forces, world frame, averaged over the frame: contacts on each body (N; N m about its origin;
  // particle contacts add theirs after the particle step), joints on their body b (N; N m about
  // b's joint frame origin)
  in("rigid.contact_forces", zeros_b, {nb, 4}, DType::FLOAT32, exportable);
  in("rigid.contact_torques", zeros_b, {nb, 4}, DType::FLOAT32, exportable);
  in("joint.reaction_forces", zeros_j, {nj, 4}, DType::FLOAT32, exportable);
  in("joint.reaction_torques", zeros_j, {nj, 4}, DType::FLOAT32, exportable);
  {  // one host-visible counter, so that the host learns of unhealthy envs without reading them all
    auto events = compute::make_typed_buffer(ctx, "env.health_events", {1}, DType::UINT32, true, false, gpu::Memory::READBACK);
    events->generation = generation;
    gpu::fill(*ctx, events->storage->buffer, 0);
    internal["env.health_events"] = events;
  }
  // scratch
  in("rigid.prev_positions", zeros_b, {nb, 4}, DType::FLOAT32);
  in("rigid.prev_rotations", zeros_b, {nb, 4}, DType::FLOAT32);
  in("joint.lambdas", zeros_j, {nj, 4}, DType::FLOAT32);
  in("rigid.delta_positions", zeros_b, {nb, 4}, DType::FLOAT32);
  in("rigid.delta_rotations", zeros_b, {nb, 4}, DType::FLOAT32);
  in("rigid.contacts", std::vector<uint32_t>{}, {ne * std::max<int64_t>(max_contacts_, 1), int64_t(sizeof(shader::Contact) / 4)}, DType::UINT32);
  // control: written by the host or by task passes
  ctl("control.joint_targets", model_.joint_targets, {nj, 4}, DType::FLOAT32);
  ctl("control.joint_reset", zeros_j, {nj, 4}, DType::FLOAT32);
  ctl("control.body_reset_velocities", zeros_b, {nb, 4}, DType::FLOAT32);
  ctl("control.body_reset_angular_velocities", zeros_b, {nb, 4}, DType::FLOAT32);
  // 1 kinematic, 0 dynamic, per body, taken at the frame's start (a body without a mass stays kinematic)
  ctl("control.body_kinematic", model_.kinematic, {nb}, DType::UINT32);
  ctl("control.body_target_positions", model_.initial_positions, {nb, 4}, DType::FLOAT32);
  ctl("control.body_target_rotations", model_.initial_rotations, {nb, 4}, DType::FLOAT32);

  auto get = [&](const std::string& k) {
    if (auto it = internal.find(k); it != internal.end()) return it->second;
    if (auto it = control.find(k); it != control.end()) return it->second;
    return scene.at(k);
  };
  step_ = compute::create_builtin_pass(
      ctx, "physics/xpbd_rigid",
      {{"env_ranges", get("rigid.env_ranges")}, {"bodies", get("rigid.bodies")}, {"colliders", get("rigid.colliders")},
       {"joints", get("joint.model")}, {"filtered_pairs", get("rigid.filtered_pairs")},
       {"dynamic_inertia", get("rigid.dynamic_inertia")}, {"body_kinematic", get("control.body_kinematic")},
       {"joint_targets", get("control.joint_targets")}, {"target_positions", get("control.body_target_positions")},
       {"target_rotations", get("control.body_target_rotations")}, {"positions", get("rigid.positions")},
       {"rotations", get("rigid.rotations")}, {"linear_velocities", get("rigid.linear_velocities")},
       {"angular_velocities", get("rigid.angular_velocities")}, {"prev_positions", get("rigid.prev_positions")},
       {"prev_rotations", get("rigid.prev_rotations")}, {"contacts", get("rigid.contacts")},
       {"delta_positions", get("rigid.delta_positions")}, {"delta_rotations", get("rigid.delta_rotations")},
       {"joint_lambdas", get("joint.lambdas")}, {"joint_positions", get("joint.positions")},
       {"contact_forces", get("rigid.contact_forces")}, {"contact_torques", get("rigid.contact_torques")},
       {"reaction_forces", get("joint.reaction_forces")}, {"reaction_torques", get("joint.reaction_torques")},
       {"joint_velocities", get("joint.velocities")}, {"transform_positions", get("transform.positions")},
       {"transform_rotations", get("transform.rotations")}, {"health", get("env.health")},
       {"reset_mask", get("env.reset_mask")}, {"health_events", get("env.health_events")}});
  reset_ = compute::create_builtin_pass(
      ctx, "physics/rigid_reset",
      {{"env_ranges", get("rigid.env_ranges")}, {"joints", get("joint.model")},
       {"reset_mask", get("env.reset_mask")}, {"initial_positions", get("rigid.initial_positions")},
       {"initial_rotations", get("rigid.initial_rotations")}, {"joint_reset", get("control.joint_reset")},
       {"reset_linear_velocities", get("control.body_reset_velocities")},
       {"reset_angular_velocities", get("control.body_reset_angular_velocities")},
       {"positions", get("rigid.positions")}, {"rotations", get("rigid.rotations")},
       {"linear_velocities", get("rigid.linear_velocities")}, {"angular_velocities", get("rigid.angular_velocities")},
       {"target_positions", get("control.body_target_positions")},
       {"target_rotations", get("control.body_target_rotations")}, {"health", get("env.health")},
       {"joint_positions", get("joint.positions")}, {"joint_velocities", get("joint.velocities")}});
  const uint32_t envs = uint32_t(ne);
  reset_->set_constant_bits("env_count", &envs, 4);
  reset_->set_threads({std::max<uint64_t>(envs, 1), 1, 1});
  step_->set_threads({std::max<uint64_t>(envs, 1), 1, 1});
  set_settings(settings);
}

uint64_t RigidSystem::health_events(const BufferMap& internal) const {
  const auto& b = internal.at("env.health_events")->storage->buffer;
  return b.mapped ? *static_cast<const volatile uint32_t*>(b.mapped) : 0;
}

void RigidSystem::set_settings(const PhysicsSettings& s) {
  s.validate();
  if (s.max_contacts_per_env != max_contacts_)
    throw std::invalid_argument("PhysicsSettings.max_contacts_per_env sizes the contact buffer: set it before "
                                "upload_world() (or call upload_world() again)");
  shader::RigidConstants c{};
  c.gravity = {s.gravity[0], s.gravity[1], s.gravity[2], s.dt};
  c.env_count = uint32_t(model_.env_ranges.size());
  c.substeps = s.substeps;
  c.iterations = s.iterations;
  c.max_contacts = s.max_contacts_per_env;
  c.max_speed = s.max_speed;
  c.max_penetration = s.max_penetration;
  if (step_->constants.size() != sizeof(c)) throw std::logic_error("RigidConstants does not match physics/xpbd_rigid");
  std::memcpy(step_->constants.data(), &c, sizeof(c));
  ++step_->version;
}

}  // namespace cressim::physics
