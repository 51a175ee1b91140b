#include "runtime/engine.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "compute/dispatch_stamps.h"
#include "gpu/error.h"
#include "cressim/layout.h"
#include "cressim/particle.h"
#include "cressim/rigid.h"
#include "scene/validate.h"

namespace cressim::runtime {
namespace {

constexpr size_t kFrameCacheSize = 8;      // distinct frame shapes kept recorded at once
constexpr uint32_t kMaxStamps = 8192;  // timestamp slots per profiled frame (ops and passes)

using compute::DType;

// authored quaternions need not be unit: shaders rotate with them as they are
std::array<float, 4> unit(const std::array<float, 4>& q) {
  const float n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  return n > 0 ? std::array<float, 4>{q[0] / n, q[1] / n, q[2] / n, q[3] / n} : std::array<float, 4>{0, 0, 0, 1};
}

std::string join(const std::vector<std::string>& v) {
  std::string s;
  for (auto& x : v) s += (s.empty() ? "" : ", ") + x;
  return s;
}

}  // namespace

Engine::Engine(std::shared_ptr<scene::World> world, const gpu::ContextOptions& options)
    : world_(std::move(world)), ctx_(gpu::create_context(options)) {
  if (!world_) throw std::invalid_argument("Engine needs a World");
  timeline_ = gpu::create_timeline(*ctx_, /*exportable=*/!ctx_->unified_memory);
  upload_cmd_ = gpu::allocate_command_buffer(*ctx_);
}

Engine::~Engine() {
  if (ctx_->device) vkDeviceWaitIdle(ctx_->device);
  release_frames();
  release_world_buffers();
  shared_.clear();
  gpu::free_command_buffer(*ctx_, upload_cmd_);
  gpu::destroy_buffer(*ctx_, staging_);
  if (timestamps_) vkDestroyQueryPool(ctx_->device, timestamps_, nullptr);
  cuda_timeline_.reset();
  gpu::destroy_timeline(*ctx_, timeline_);
}

// ---- authoring -> GPU ----------------------------------------------------------------------

void Engine::prepare() {
  prepared_ = false;
  scene::validate_world(*world_);  // every field, before any model is built from it
  mapping_ = scene::build_layout_mapping(*world_);
  rigid_model_ = physics::build_rigid_model(*world_, mapping_);
  particle_model_ = physics::build_particle_model(*world_, mapping_);
  for (auto& n : particle_model_.needles) n.ids.x = uint32_t(rigid_model_.entity_body[n.ids.x]);  // entity -> body
  const auto& limits = ctx_->properties.limits;
  render_model_ = render::build_render_model(*world_, mapping_,
                                             std::min(limits.maxImageArrayLayers, limits.maxFramebufferLayers),
                                             particle_model_);
  ultrasound_model_ = sensors::build_ultrasound_model(*world_, mapping_, particle_model_);
  prepared_ = true;
  uploaded_ = false;
}

void Engine::upload_world() {
  if (!prepared_ || mapping_.topology_version != world_->topology_version())
    throw TopologyError("upload_world(): call prepare() first" +
                        std::string(prepared_ ? " (the world changed since: " + world_->last_topology_change() + ")" : ""));
  vkDeviceWaitIdle(ctx_->device);
  release_frames();
  release_world_buffers();
  ++generation_;
  ++epoch_;
  const auto rows = int64_t(mapping_.rows()), envs = int64_t(mapping_.num_envs);

  auto internal = [&](const std::string& key, std::vector<int64_t> shape, DType t) {
    auto b = compute::make_typed_buffer(ctx_, key, std::move(shape), t, true);
    b->generation = generation_;
    internal_[key] = b;
    return b;
  };
  auto put = [&](const std::shared_ptr<compute::TypedBuffer>& b, const void* data) {
    gpu::upload(*ctx_, b->storage->buffer, data, b->bytes());
  };

  // entity rows and the per-env ranges, as prepared
  put(internal("entity.id", {rows}, DType::UINT32), mapping_.row_entity.data());
  put(internal("entity.env", {rows}, DType::UINT32), mapping_.row_env.data());
  put(internal("env.entity_offset", {envs}, DType::UINT32), mapping_.env_offset.data());
  put(internal("env.entity_count", {envs}, DType::UINT32), mapping_.env_count.data());
  gpu::fill(*ctx_, internal("env.reset_count", {envs}, DType::UINT32)->storage->buffer, 0);

  // transforms as float4 rows (xyz + pad, quaternion xyzw, scale + pad)
  std::vector<float> pos(size_t(rows) * 4, 0.f), rot(size_t(rows) * 4, 0.f), scl(size_t(rows) * 4, 0.f);
  for (int64_t r = 0; r < rows; ++r) {
    const auto e = mapping_.row_entity[size_t(r)];
    scene::Transform t = world_->has<scene::Transform>(e) ? world_->get<scene::Transform>(e) : scene::Transform{};
    std::copy(t.position.begin(), t.position.end(), &pos[size_t(r) * 4]);
    pos[size_t(r) * 4 + 3] = 1.f;
    const auto q = unit(t.rotation);
    std::copy(q.begin(), q.end(), &rot[size_t(r) * 4]);
    std::copy(t.scale.begin(), t.scale.end(), &scl[size_t(r) * 4]);
  }
  for (const char* k : {"transform.positions", "transform.initial_positions"}) put(internal(k, {rows, 4}, DType::FLOAT32), pos.data());
  for (const char* k : {"transform.rotations", "transform.initial_rotations"}) put(internal(k, {rows, 4}, DType::FLOAT32), rot.data());
  put(internal("transform.scales", {rows, 4}, DType::FLOAT32), scl.data());
  world_->take_dirty();  // uploaded just now

  // the engine's own read-write buffer: tasks and the health check flag envs to reset
  auto mask = compute::make_typed_buffer(ctx_, "env.reset_mask", {envs}, DType::UINT32, false);
  gpu::fill(*ctx_, mask->storage->buffer, 0);
  shared_[mask->key] = mask;

  reset_pass_ = compute::create_builtin_pass(
      ctx_, "scene/reset_envs",
      {{"entity_env", internal_["entity.env"]}, {"reset_mask", mask},
       {"initial_positions", internal_["transform.initial_positions"]},
       {"initial_rotations", internal_["transform.initial_rotations"]},
       {"positions", internal_["transform.positions"]}, {"rotations", internal_["transform.rotations"]},
       {"reset_count", internal_["env.reset_count"]}});
  const shader::ResetEnvsConstants rc{uint32_t(rows), uint32_t(envs)};
  reset_pass_->set_constant_bits("row_count", &rc.row_count, sizeof(rc.row_count));
  reset_pass_->set_constant_bits("env_count", &rc.env_count, sizeof(rc.env_count));
  reset_pass_->set_threads({uint64_t(std::max(rows, envs)), 1, 1});

  if (!rigid_model_.empty()) {
    physics::BufferMap scene = internal_;
    scene.insert(shared_.begin(), shared_.end());
    rigid_ = std::make_unique<physics::RigidSystem>(ctx_, rigid_model_, physics_settings_, generation_, internal_,
                                                     shared_, scene);
  }
  if (!particle_model_.empty()) {
    physics::BufferMap scene = internal_;
    scene.insert(shared_.begin(), shared_.end());
    bool dynamic = false;
    for (auto& b : rigid_model_.bodies) dynamic = dynamic || b.inv_inertia.w > 0;
    particles_ = std::make_unique<physics::ParticleSystem>(ctx_, particle_model_, physics_settings_, generation_,
                                                           internal_, shared_, scene, rigid_ != nullptr, dynamic);
  }
  if (!render_model_.empty()) renderer_ = std::make_unique<render::Renderer>(ctx_, render_model_, generation_, internal_, internal_);
  if (!ultrasound_model_.empty())
    ultrasound_ = std::make_unique<sensors::UltrasoundSensor>(ctx_, ultrasound_model_, generation_, internal_, internal_);
  reported_health_events_ = 0;
  uploaded_ = true;
}

void Engine::release_world_buffers() {
  ultrasound_.reset();
  renderer_.reset();
  particles_.reset();
  rigid_.reset();
  reset_pass_.reset();
  internal_.clear();
  // engine-owned writable buffers (dotted names); the user's shared buffers stay
  for (auto it = shared_.begin(); it != shared_.end();)
    it = it->first.find('.') != std::string::npos ? shared_.erase(it) : std::next(it);
}

void Engine::set_physics_settings(const physics::PhysicsSettings& s) {
  s.validate();
  if (rigid_) rigid_->set_settings(s);
  if (particles_) particles_->set_settings(s);
  physics_settings_ = s;
  ++epoch_;
}

// ---- resources ---------------------------------------------------------------------------

std::shared_ptr<compute::TypedBuffer> Engine::create_shared_buffer(const std::string& name, std::vector<int64_t> shape,
                                                                   DType dtype) {
  if (name.empty()) throw std::invalid_argument("create_shared_buffer: name must not be empty");
  if (internal_.count(name) || shared_.count(name))
    throw std::invalid_argument("create_shared_buffer: the name '" + name + "' is taken");
  if (name.find('.') != std::string::npos)
    throw std::invalid_argument("create_shared_buffer: '" + name + "': dotted names are reserved for engine buffers");
  auto b = compute::make_typed_buffer(ctx_, name, std::move(shape), dtype, false, ctx_->external_memory_fd &&
                                                                                      !ctx_->unified_memory);
  gpu::fill(*ctx_, b->storage->buffer, 0);
  shared_[name] = b;
  return b;
}

std::shared_ptr<compute::TypedBuffer> Engine::lookup(const std::string& key) const {
  if (auto it = shared_.find(key); it != shared_.end()) return it->second;
  if (auto it = internal_.find(key); it != internal_.end()) return it->second;
  std::string hint = uploaded_ ? "" : " (internal buffers exist after upload_world())";
  throw compute::BindingError("unknown buffer key '" + key + "'" + hint + "; valid keys: " +
                              join(shared_names()) + (shared_.empty() ? "" : ", ") + join(internal_keys()));
}

std::vector<std::string> Engine::internal_keys() const {
  std::vector<std::string> k;
  for (auto& [name, b] : internal_) k.push_back(name);
  return k;
}

std::vector<std::string> Engine::shared_names() const {
  std::vector<std::string> k;
  for (auto& [name, b] : shared_) k.push_back(name);
  return k;
}

std::shared_ptr<compute::ComputePass> Engine::create_compute_pass(compute::PassSpec spec,
                                                                  const std::map<std::string, std::string>& keys) {
  for (auto& [hlsl_name, key] : keys) {
    try {
      spec.bindings[hlsl_name] = lookup(key);
    } catch (const compute::BindingError& e) {
      throw compute::BindingError("pass '" + spec.name + "', binding '" + hlsl_name + "': " + e.what());
    }
  }
  return compute::create_compute_pass(ctx_, spec);
}

const scene::LayoutMapping& Engine::mapping() const {
  if (!prepared_) throw TopologyError("the layout mapping exists after prepare()");
  return mapping_;
}

std::vector<std::string> Engine::validation_messages() {
  std::lock_guard<std::mutex> lock(ctx_->messages_mutex);
  return ctx_->validation_messages;
}

void Engine::add_stage_recorder(Stage stage, StageRecorder r) {
  recorders_[size_t(stage)].push_back(std::move(r));
  ++epoch_;
}

// ---- host writes -------------------------------------------------------------------------

void Engine::write_rows(compute::TypedBuffer& dst, uint32_t row, const void* data, uint32_t row_bytes) {
  const VkDeviceSize offset = VkDeviceSize(row) * row_bytes;
  if (dst.storage->buffer.mapped) {
    std::memcpy(static_cast<char*>(dst.storage->buffer.mapped) + offset, data, row_bytes);
    return;
  }
  VkBufferCopy c{staged_bytes_.size(), offset, row_bytes};
  staged_bytes_.insert(staged_bytes_.end(), static_cast<const uint8_t*>(data),
                       static_cast<const uint8_t*>(data) + row_bytes);
  staged_copies_.push_back({dst.storage->buffer.buffer, c});
}

void Engine::reset_envs(const std::vector<uint32_t>& envs) {
  require_current_topology("reset_envs()");
  auto& mask = *shared_.at("env.reset_mask");
  const uint32_t one = 1;
  for (uint32_t env : envs) {
    if (env >= mapping_.num_envs)
      throw std::out_of_range("reset_envs: env " + std::to_string(env) + " is out of range (" +
                              std::to_string(mapping_.num_envs) + " envs)");
    write_rows(mask, env, &one, 4);
  }
}

void Engine::flush_host_writes() {
  // authored values changed since the last frame (poses, targets): O(changed entities)
  for (scene::EntityId e : world_->take_dirty()) {
    if (!world_->has<scene::Transform>(e)) continue;
    const auto& t = world_->get<scene::Transform>(e);
    const uint32_t row = mapping_.entity_row[e];
    const float p[4] = {t.position[0], t.position[1], t.position[2], 1.f};
    const float s[4] = {t.scale[0], t.scale[1], t.scale[2], 0.f};
    for (const char* k : {"transform.positions", "transform.initial_positions"}) write_rows(*internal_.at(k), row, p, 16);
    const auto q = unit(t.rotation);
    for (const char* k : {"transform.rotations", "transform.initial_rotations"}) write_rows(*internal_.at(k), row, q.data(), 16);
    write_rows(*internal_.at("transform.scales"), row, s, 16);
    // a rigid body follows: kinematic ones move there over the next step, dynamic ones jump
    const int64_t body = rigid_ ? rigid_->body_of(e) : -1;
    if (body < 0) continue;
    const bool kinematic = rigid_->model().bodies[size_t(body)].ids.z & shader::BODY_KINEMATIC;
    std::vector<const char*> positions{"control.body_target_positions"}, rotations{"control.body_target_rotations"};
    if (!kinematic) {
      positions.insert(positions.end(), {"rigid.positions", "rigid.initial_positions"});
      rotations.insert(rotations.end(), {"rigid.rotations", "rigid.initial_rotations"});
    }
    for (const char* k : positions) write_rows(*lookup(k), uint32_t(body), p, 16);
    for (const char* k : rotations) write_rows(*lookup(k), uint32_t(body), q.data(), 16);
  }
}

// ---- the frame ---------------------------------------------------------------------------

void Engine::require_current_topology(const char* what) const {
  if (!uploaded_) throw TopologyError(std::string(what) + ": call prepare() and upload_world() first");
  if (mapping_.topology_version != world_->topology_version())
    throw TopologyError(std::string(what) + ": the scene's topology changed after prepare() (" +
                        world_->last_topology_change() + "); call prepare() and upload_world() again");
}

void Engine::push(Stage stage) {
  require_current_topology(stage_name(stage));
  ops_.push_back({stage, nullptr, 0, 0});
}

void Engine::execute_compute_pass(const std::shared_ptr<compute::ComputePass>& pass) {
  require_current_topology("execute_compute_pass()");
  if (!pass) throw std::invalid_argument("execute_compute_pass: no pass");
  for (auto& [name, b] : pass->bindings)
    if (b->read_only && b->generation != generation_)
      throw TopologyError("pass '" + pass->name + "' binds '" + b->key +
                          "' from an earlier upload_world(); create the pass again");
  ops_.push_back({Stage::CUSTOM_PASS, pass, pass->uid, pass->version});
}

RecordedFrame& Engine::frame_for(const std::vector<FrameOp>& ops) {
  for (auto& f : frames_cache_)
    if (f.epoch == epoch_ && f.profiled == profiling_ && f.passes == (profiling_ && profile_passes_) && f.ops == ops)
      return f;
  // evict the least recently used, then record the new shape once
  if (frames_cache_.size() >= kFrameCacheSize) {
    auto lru = std::min_element(frames_cache_.begin(), frames_cache_.end(),
                                [](auto& a, auto& b) { return a.last_used < b.last_used; });
    gpu::free_command_buffer(*ctx_, lru->cmd);
    frames_cache_.erase(lru);
  }
  frames_cache_.push_back({ops, epoch_, profiling_, profiling_ && profile_passes_, {}, {},
                           gpu::allocate_command_buffer(*ctx_), 0});
  record(frames_cache_.back());
  return frames_cache_.back();
}

void Engine::record_op(VkCommandBuffer cmd, const FrameOp& op) {
  if (op.stage == Stage::CUSTOM_PASS) op.pass->record(cmd);
  else if (op.stage == Stage::UPLOAD || op.stage == Stage::RESET) {
    // env resets requested by the host, a task pass or the health check, then clear the flags
    reset_pass_->record(cmd);
    if (rigid_) rigid_->record_reset(cmd);
    if (particles_) particles_->record_reset(cmd);
    gpu::compute_barrier(cmd);
    vkCmdFillBuffer(cmd, shared_.at("env.reset_mask")->storage->buffer.buffer, 0, VK_WHOLE_SIZE, 0);
  } else if (op.stage == Stage::PHYSICS) {
    // particles after the frame's rigid step: they collide with the bodies placed along it
    if (rigid_) rigid_->record_step(cmd);
    if (rigid_ && particles_) gpu::compute_barrier(cmd);
    if (particles_) particles_->record_step(cmd);
  } else if (op.stage == Stage::VISUAL_SENSORS && renderer_) {
    renderer_->record(cmd);
  } else if (op.stage == Stage::SIMULATION_SENSORS && ultrasound_) {
    ultrasound_->record(cmd);
  }
  for (auto& r : recorders_[size_t(op.stage)]) r(cmd);
}

void Engine::record(RecordedFrame& f) {
  if (f.profiled && !timestamps_) {
    VkQueryPoolCreateInfo qi{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
    qi.queryType = VK_QUERY_TYPE_TIMESTAMP;
    qi.queryCount = kMaxStamps;
    gpu::check(vkCreateQueryPool(ctx_->device, &qi, nullptr, &timestamps_), "vkCreateQueryPool");
  }
  VkCommandBuffer cmd = f.cmd;
  gpu::begin_commands(cmd, false);
  std::vector<FrameOp> all{{Stage::UPLOAD, nullptr, 0, 0}};
  all.insert(all.end(), f.ops.begin(), f.ops.end());
  compute::DispatchStamps stamps{timestamps_, kMaxStamps, f.passes};
  if (f.profiled) {
    vkCmdResetQueryPool(cmd, timestamps_, 0, kMaxStamps);
    stamps.stamp(cmd, "");
    compute::active_dispatch_stamps() = &stamps;
  }
  for (size_t i = 0; i < all.size(); ++i) {
    stamps.op = int(i);
    record_op(cmd, all[i]);
    gpu::compute_barrier(cmd);
    if (f.profiled) stamps.stamp(cmd, "(rest)");
  }
  compute::active_dispatch_stamps() = nullptr;
  if (f.profiled && !stamps.overflowed) {
    f.stamp_labels = std::move(stamps.labels);
    f.stamp_ops = std::move(stamps.ops);
  }
  gpu::host_read_barrier(cmd);
  gpu::end_commands(cmd);
  ++recorded_;
}

void Engine::end_frame() {
  require_current_topology("end_frame()");
  flush_host_writes();
  RecordedFrame& frame = frame_for(ops_);
  frame.last_used = frames_;

  std::vector<VkCommandBuffer> cmds;
  if (!staged_copies_.empty()) {
    if (staging_.size < staged_bytes_.size()) {
      gpu::destroy_buffer(*ctx_, staging_);
      staging_ = gpu::create_buffer(*ctx_, std::max<VkDeviceSize>(staged_bytes_.size(), 1 << 16), {gpu::Memory::UPLOAD});
    }
    std::memcpy(staging_.mapped, staged_bytes_.data(), staged_bytes_.size());
    gpu::begin_commands(upload_cmd_, true);
    for (auto& [dst, region] : staged_copies_) vkCmdCopyBuffer(upload_cmd_, staging_.buffer, dst, 1, &region);
    gpu::compute_barrier(upload_cmd_);
    gpu::end_commands(upload_cmd_);
    cmds.push_back(upload_cmd_);
  }
  cmds.push_back(frame.cmd);

  last_stage_ = frame.ops.empty() ? "upload" : frame.ops.back().label();
  // CUDA work that wrote inputs (actions) signals the timeline; the frame waits for it on the GPU
  uint64_t cuda_value = 0;
  if (cuda_stream_ && cuda_host_sync_) {
    compute::synchronize_cuda_stream(cuda_device_, cuda_stream_);
  } else if (cuda_timeline_) {
    cuda_value = timeline_.value + 1;
    cuda_timeline_->signal(cuda_value, cuda_stream_);
  }
  const uint64_t value = gpu::submit(*ctx_, timeline_, cmds, last_stage_, cuda_value);
  ++submits_;
  ops_.clear();
  staged_bytes_.clear();
  staged_copies_.clear();
  gpu::wait(*ctx_, timeline_, value, last_stage_);
  ++frames_;

  // report envs the solver flagged this frame (one host-visible counter, O(1))
  if (const uint64_t events = health_events(); events > reported_health_events_) {
    std::fprintf(stderr, "cressim: warning: %llu env(s) flagged unhealthy (NaN, speed or penetration) in frame %llu "
                 "and reset; env.health says which and why\n",
                 static_cast<unsigned long long>(events - reported_health_events_),
                 static_cast<unsigned long long>(frames_));
    reported_health_events_ = events;
  }

  if (frame.profiled && !frame.stamp_labels.empty()) {
    const size_t n = frame.stamp_labels.size();
    std::vector<uint64_t> ticks(n);
    gpu::check(vkGetQueryPoolResults(ctx_->device, timestamps_, 0, uint32_t(n), n * 8, ticks.data(), 8,
                                     VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
               "vkGetQueryPoolResults");
    const double ms_per_tick = ctx_->properties.limits.timestampPeriod * 1e-6;
    const auto label = [&](int op) { return op == 0 ? std::string("upload") : frame.ops[size_t(op) - 1].label(); };
    timings_.assign(frame.ops.size() + 1, {});
    for (size_t i = 0; i < timings_.size(); ++i) timings_[i].first = label(int(i));
    pass_timings_.clear();
    for (size_t i = 1; i < n; ++i) {
      const double ms = double(ticks[i] - ticks[i - 1]) * ms_per_tick;
      const int op = frame.stamp_ops[i];
      timings_[size_t(op)].second += ms;
      if (frame.passes) pass_timings_.emplace_back(label(op), frame.stamp_labels[i], ms);
    }
  }
}

uint64_t Engine::health_events() const {
  return rigid_ ? rigid_->health_events(internal_) : particles_ ? particles_->health_events(internal_) : 0;
}

uint32_t Engine::attachment_row(uint32_t env, uint32_t slot, const char* what) const {
  require_current_topology(what);
  const uint32_t per_env = particles_ ? particles_->attachments_per_env() : 0;
  if (env >= mapping_.num_envs)
    throw std::out_of_range(std::string(what) + ": env " + std::to_string(env) + " is out of range (" +
                            std::to_string(mapping_.num_envs) + " envs)");
  if (slot >= per_env)
    throw std::out_of_range(std::string(what) + ": slot " + std::to_string(slot) + " of env " + std::to_string(env) +
                            " is out of range (PhysicsSettings.max_particle_attachments_per_env = " +
                            std::to_string(per_env) + (particles_ ? "" : "; the scene has no particles") + ")");
  return env * per_env + slot;
}

void Engine::attach_particle(uint32_t env, uint32_t slot, uint32_t particle, uint32_t body_entity, float compliance,
                             bool hold_frame, const std::optional<std::array<float, 4>>& frame_offset) {
  const uint32_t row = attachment_row(env, slot, "attach_particle()");
  const auto& pm = particles_->model();
  if (particle >= pm.size() || pm.phases[particle].z != env)
    throw std::out_of_range("attach_particle: particle " + std::to_string(particle) + " is not a particle of env " +
                            std::to_string(env) + " (engine.particle_mapping says which are)");
  const int64_t body = rigid_ ? rigid_->body_of(body_entity) : -1;
  if (body < 0 || world_->env_of(body_entity) != env)
    throw std::invalid_argument("attach_particle: " + world_->describe(body_entity) + " is not a rigid body of env " +
                                std::to_string(env));
  if (!(compliance >= 0)) throw std::invalid_argument("attach_particle: compliance must be >= 0");
  shader::ParticleAttachment a{{particle, uint32_t(body), shader::ATTACH_PENDING, env}, {0, 0, 0, compliance},
                               {shader::CRESSIM_NONE, shader::HOLD_FRAME_CAPTURE, 0, 0}, {0, 0, 0, 1}};
  if (hold_frame) hold_frame_of(a, frame_offset);
  else if (frame_offset) throw std::invalid_argument("attach_particle: frame_offset needs hold_frame=True");
  write_rows(*shared_.at("control.particle_attachments"), row, &a, sizeof(a));
}

void Engine::release_particle(uint32_t env, uint32_t slot) {
  const uint32_t row = attachment_row(env, slot, "release_particle()");
  shader::ParticleAttachment a{{0, 0, shader::ATTACH_FREE, env}, {0, 0, 0, 0}, {shader::CRESSIM_NONE, 0, 0, 0}, {0, 0, 0, 1}};
  write_rows(*shared_.at("control.particle_attachments"), row, &a, sizeof(a));
}

void Engine::set_cuda_stream(uintptr_t stream, bool host_sync) {
  cuda_stream_ = stream;
  cuda_host_sync_ = host_sync;
  if (!stream) cuda_timeline_.reset();
  else cuda_device_ = compute::cuda_device_of(*ctx_);
  if (stream && !host_sync && !cuda_timeline_) cuda_timeline_ = compute::import_timeline(*ctx_, timeline_);
}

void Engine::release_frames() {
  for (auto& f : frames_cache_) gpu::free_command_buffer(*ctx_, f.cmd);
  frames_cache_.clear();
}

}  // namespace cressim::runtime
