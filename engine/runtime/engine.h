// The runtime: authoring -> prepare() -> upload_world() -> frames of stages -> end_frame().
#pragma once
#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "compute/compute_pass.h"
#include "compute/typed_buffer.h"
#include "gpu/commands.h"
#include "gpu/context.h"
#include "physics/particle_system.h"
#include "physics/rigid_system.h"
#include "physics/settings.h"
#include "render/renderer.h"
#include "runtime/frame.h"
#include "scene/layout_mapping.h"
#include "scene/world.h"
#include "sensors/ultrasound_sensor.h"

namespace cressim::runtime {

// The world's topology changed after prepare(), or the engine is used out of order.
struct TopologyError : std::logic_error {
  using std::logic_error::logic_error;
};

// A system's contribution to one stage of the frame (physics solvers, cameras, sensors).
using StageRecorder = std::function<void(VkCommandBuffer)>;

class Engine {
 public:
  explicit Engine(std::shared_ptr<scene::World> world, const gpu::ContextOptions& options = gpu::options_from_environment());
  ~Engine();
  Engine(const Engine&) = delete;
  Engine& operator=(const Engine&) = delete;

  // authoring -> GPU
  void prepare();
  void upload_world();

  // the frame: any order of stages and passes, then end_frame() submits it once and waits
  void step_physics() { push(Stage::PHYSICS); }
  // resets the envs flagged so far in this frame (every frame also starts with one)
  void reset_flagged_envs() { push(Stage::RESET); }
  void step_visual_sensors() { push(Stage::VISUAL_SENSORS); }
  void step_simulation_sensors() { push(Stage::SIMULATION_SENSORS); }
  void execute_compute_pass(const std::shared_ptr<compute::ComputePass>& pass);
  void end_frame();

  // resources
  std::shared_ptr<compute::TypedBuffer> create_shared_buffer(const std::string& name, std::vector<int64_t> shape,
                                                             compute::DType dtype);
  // bindings: HLSL name -> shared buffer name or internal key (resolved by lookup())
  std::shared_ptr<compute::ComputePass> create_compute_pass(compute::PassSpec spec,
                                                            const std::map<std::string, std::string>& keys);
  std::shared_ptr<compute::TypedBuffer> lookup(const std::string& key) const;  // shared first, then internal
  std::vector<std::string> internal_keys() const;
  std::vector<std::string> shared_names() const;

  // physics settings apply from the next frame
  const physics::PhysicsSettings& physics_settings() const { return physics_settings_; }
  void set_physics_settings(const physics::PhysicsSettings& s);
  const physics::RigidSystem* rigid() const { return rigid_.get(); }
  const physics::ParticleSystem* particles() const { return particles_.get(); }
  // rigid-particle attachment slot `slot` of `env`: ties `particle` (global index) to the rigid
  // body of `body_entity` where both are at the next step; release frees the slot. No reallocation.
  // hold_frame (strand particles): the segment at that end keeps its material frame at
  // body rotation * frame_offset (xyzw; without one, the offset where both are at the next step).
  void attach_particle(uint32_t env, uint32_t slot, uint32_t particle, uint32_t body_entity, float compliance = 0,
                       bool hold_frame = false, const std::optional<std::array<float, 4>>& frame_offset = std::nullopt);
  void release_particle(uint32_t env, uint32_t slot);
  // (particle_edits.cpp) fluid particles (global indices) become inactive slots at the next step;
  // constraints (rows of particles.<family>_constraints) are switched off (cut) or on again
  void remove_particles(const std::vector<uint32_t>& particles);
  void cut_constraints(const std::string& family, const std::vector<uint32_t>& rows, bool cut = true);
  const render::Renderer* renderer() const { return renderer_.get(); }
  const sensors::UltrasoundSensor* ultrasound() const { return ultrasound_.get(); }
  // envs the solver flagged (NaN, speed, penetration) and reset since upload_world()
  uint64_t health_events() const;

  // env control: envs flagged here (or in env.reset_mask by a pass) reset at the next frame
  void reset_envs(const std::vector<uint32_t>& envs);

  // introspection
  const scene::LayoutMapping& mapping() const;
  const std::shared_ptr<scene::World>& world() const { return world_; }
  std::shared_ptr<gpu::Context> context() const { return ctx_; }
  bool prepared() const { return prepared_; }
  bool uploaded() const { return uploaded_; }
  uint64_t frame_count() const { return frames_; }
  uint64_t recorded_frames() const { return recorded_; }  // command-buffer recordings so far
  uint64_t submits() const { return submits_; }
  std::vector<std::string> validation_messages();
  // frames wait for the work queued so far on this CUDA stream (0: none): on the GPU through
  // the shared timeline semaphore, or, with host_sync, by a host wait before the submit
  void set_cuda_stream(uintptr_t stream, bool host_sync = false);
  uintptr_t cuda_stream() const { return cuda_stream_; }
  bool cuda_host_sync() const { return cuda_host_sync_; }
  void set_profiling(bool on) { profiling_ = on; }
  bool profiling() const { return profiling_; }
  // with profiling on, also a timestamp after every compute pass (last_pass_timings)
  void set_profile_passes(bool on) { profile_passes_ = on; }
  bool profile_passes() const { return profile_passes_; }
  // (op label, milliseconds) of the last profiled frame
  const std::vector<std::pair<std::string, double>>& last_timings() const { return timings_; }
  // (op label, pass name, milliseconds) of the last frame profiled with passes, in recorded order;
  // "(rest)" is the op's work after its last pass (draws, copies, barriers)
  const std::vector<std::tuple<std::string, std::string, double>>& last_pass_timings() const { return pass_timings_; }
  void add_stage_recorder(Stage stage, StageRecorder r);

 private:
  void push(Stage stage);
  void require_current_topology(const char* what) const;
  void flush_host_writes();
  RecordedFrame& frame_for(const std::vector<FrameOp>& ops);
  void record(RecordedFrame& f);
  void record_op(VkCommandBuffer cmd, const FrameOp& op);
  void release_frames();
  void release_world_buffers();
  void write_rows(compute::TypedBuffer& dst, uint32_t row, const void* data, uint32_t row_bytes);
  uint32_t attachment_row(uint32_t env, uint32_t slot, const char* what) const;
  void hold_frame_of(shader::ParticleAttachment& a, const std::optional<std::array<float, 4>>& offset) const;

  std::shared_ptr<scene::World> world_;
  std::shared_ptr<gpu::Context> ctx_;
  gpu::Timeline timeline_;
  uintptr_t cuda_stream_ = 0;
  bool cuda_host_sync_ = false;
  int cuda_device_ = -1;
  std::shared_ptr<compute::CudaTimeline> cuda_timeline_;
  VkQueryPool timestamps_ = VK_NULL_HANDLE;
  std::vector<std::pair<std::string, double>> timings_;
  std::vector<std::tuple<std::string, std::string, double>> pass_timings_;

  bool prepared_ = false, uploaded_ = false, profiling_ = false, profile_passes_ = false;
  scene::LayoutMapping mapping_;
  uint64_t epoch_ = 1;  // bumps whenever resources a recorded frame refers to change
  uint64_t generation_ = 0;  // upload_world() count; internal buffers carry it
  std::map<std::string, std::shared_ptr<compute::TypedBuffer>> internal_, shared_;
  std::array<std::vector<StageRecorder>, 7> recorders_;
  physics::PhysicsSettings physics_settings_;
  physics::RigidModel rigid_model_;  // built by prepare(), moved to rigid_ by upload_world()
  std::unique_ptr<physics::RigidSystem> rigid_;
  physics::ParticleModel particle_model_;  // built by prepare(), moved to particles_ by upload_world()
  std::unique_ptr<physics::ParticleSystem> particles_;
  render::RenderModel render_model_;  // built by prepare(), moved to renderer_ by upload_world()
  std::unique_ptr<render::Renderer> renderer_;
  sensors::UltrasoundModel ultrasound_model_;  // built by prepare(), moved to ultrasound_ by upload_world()
  std::unique_ptr<sensors::UltrasoundSensor> ultrasound_;
  std::shared_ptr<compute::ComputePass> reset_pass_;

  std::vector<FrameOp> ops_;
  std::vector<RecordedFrame> frames_cache_;
  uint64_t frames_ = 0, recorded_ = 0, submits_ = 0;
  std::string last_stage_;
  uint64_t reported_health_events_ = 0;

  // host writes for memory the host cannot map: staged, copied at the head of the next submit
  gpu::Buffer staging_;
  std::vector<uint8_t> staged_bytes_;
  std::vector<std::pair<VkBuffer, VkBufferCopy>> staged_copies_;
  VkCommandBuffer upload_cmd_ = VK_NULL_HANDLE;
};

}  // namespace cressim::runtime
