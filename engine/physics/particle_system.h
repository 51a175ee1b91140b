// The particle system on the GPU (soft bodies, fluids, strands, batched over envs): its buffers
// (keys particles.*, control.particle_attachments, control.particle_remove and
// control.particle_<family>_cut), the substep loop recorded into
// step_physics after the rigid solver, and the per-env reset.
//
// Per frame first: fluid removals (control.particle_remove) make slots inactive, then fluid
// emitters activate inactive slots.
// Per substep: integrate; neighbour grid keyed on (env, cell) (count, prefix sum, scatter, sort
// each bucket, list each particle's neighbours); `particle_iterations` times every constraint family colour by colour (one
// dispatch per colour, or one workgroup per env for all colours), and in
// `particle_contact_iterations` of those (spread evenly) first fluid densities and after the
// families neighbour corrections (fluid density, particle contacts), the gather (those
// corrections + rigid collider contacts with friction), dynamic bodies' share of those contacts
// (two-way coupling) and attachments; then velocities and the fluid velocity terms. At the
// frame's end, env health.
#pragma once
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "compute/compute_pass.h"
#include "physics/particle_model.h"
#include "physics/rigid_system.h"
#include "physics/settings.h"

namespace cressim::physics {

class ParticleSystem {
 public:
  // internal: read-only engine buffers (keys added); control: writable ones (keys added);
  // scene: env flags, and the rigid system's buffers when there is one (has_rigid); particles
  // push dynamic bodies back when there are any (dynamic_bodies).
  ParticleSystem(std::shared_ptr<gpu::Context> ctx, ParticleModel model, const PhysicsSettings& settings,
                 uint64_t generation, BufferMap& internal, BufferMap& control, const BufferMap& scene, bool has_rigid,
                 bool dynamic_bodies);

  // max_particle_attachments_per_env sizes a buffer: it can change only with a new upload_world()
  void set_settings(const PhysicsSettings& s);
  void record_step(VkCommandBuffer cmd) const;
  void record_reset(VkCommandBuffer cmd) const;
  const ParticleModel& model() const { return model_; }
  uint32_t attachments_per_env() const { return attachments_per_env_; }
  uint64_t health_events(const BufferMap& internal) const;

 private:
  std::shared_ptr<compute::ComputePass> pass(const std::string& shader, uint64_t threads);
  void frame_weights(const PhysicsSettings& s);
  void set_constants(const PhysicsSettings& s);
  uint32_t heat_cycles(const PhysicsSettings& s) const;  // explicit heat steps a frame (0: no heat)
  void record_families(VkCommandBuffer cmd, uint32_t passes) const;

  std::shared_ptr<gpu::Context> ctx_;
  ParticleModel model_;
  PhysicsSettings settings_;
  bool has_rigid_ = false;
  uint32_t table_size_ = 0, blocks_ = 0, attachments_per_env_ = 0;
  std::map<std::string, std::shared_ptr<compute::TypedBuffer>> bindings_;  // HLSL name -> buffer
  std::vector<VkBuffer> per_substep_clears_;  // zeroed at each substep start (multipliers)
  std::vector<VkBuffer> grid_clears_;  // zeroed before each neighbour-grid build (its counters)
  VkBuffer frame_clear_ = VK_NULL_HANDLE;     // zeroed at each frame start (particle forces on bodies)
  std::vector<std::shared_ptr<compute::ComputePass>> all_;
  std::shared_ptr<compute::ComputePass> emit_, integrate_, collider_near_, orient_integrate_, orient_velocity_, grid_count_, scan_local_, scan_blocks_, scan_add_, scatter_, sort_, neighbor_list_,
      fluid_lambda_, neighbors_, gather_, rigid_push_, rigid_hold_, rigid_forces_, heat_cover_, heat_flow_, heat_apply_, coagulate_, coagulate_reset_, attach_, support_, velocity_, vorticity_,
      fluid_velocity_, tendon_, tendon_force_, needle_detect_, needle_solve_, needle_reset_, needle_load_,
      health_, reset_, remove_;
  // a substep's iterations in one workgroup per env (particle_iterations), where the model allows it
  std::shared_ptr<compute::ComputePass> iterations_;
  bool iterations_list_ = false;  // iterations_ lists the neighbours itself: the grid's passes do not run
  // a non-empty constraint set: its pass dispatched once per colour, and for positional
  // families whose envs fit in group memory the one-workgroup-per-env pass
  struct Family {
    // per_env's records refreshed each frame (particle_block_pack), for families on particle_solve.hlsli
    std::shared_ptr<compute::ComputePass> per_colour, per_env, pack;
    const ConstraintSet* set;
  };
  bool workgroup_solve(const Family& f) const;  // this family's schedule under the settings
  std::vector<Family> families_;
  // passes that place moving bodies along the frame (their constants carry the substep's progress)
  std::vector<compute::ComputePass*> moving_;
  uint32_t largest_env_ = 0, largest_env_index_ = 0;  // particles of the biggest env
  uint32_t heat_flow_items_ = 0;                       // the tets' solved particles (particle_heat_flow)
  uint32_t coagulate_items_ = 0;                       // tets (particle_tet_coagulate)
  // per family: the env reset of its cut flags, and its record count
  std::vector<std::pair<std::shared_ptr<compute::ComputePass>, uint32_t>> cut_resets_;
};

}  // namespace cressim::physics
