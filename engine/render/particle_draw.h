// Particles drawn from the physics buffers, with no host copy: one pass writes the vertices of
// soft-body surfaces and strand tubes (particle_vertices.comp.hlsl) before the rasterizer reads
// them; per camera group, fluids are splatted as spheres, smoothed and shaded in screen space
// (fluid_*.comp.hlsl) over the group's finished outputs, so both rasterizers get the same fluid.
#pragma once
#include <memory>
#include <vector>

#include "compute/compute_pass.h"
#include "render/render_model.h"

namespace cressim::render {

using BufferMap = compute::BufferMap;

class ParticleDraw {
 public:
  // scene: engine buffers (particles.*); bound: the rasterizer's buffers by shader name
  ParticleDraw(std::shared_ptr<gpu::Context> ctx, const RenderModel& model, uint64_t generation, BufferMap& internal,
               const BufferMap& scene, const BufferMap& bound);
  bool has_fluid() const { return has_fluid_; }
  // a camera group's fluid passes: outputs holds out_rgb, out_segmentation (or stand-ins) and
  // scene_depth (the group's metric depth, written by the rasterizer even when not a product)
  void add_group(uint32_t group, const BufferMap& outputs, uint32_t products);
  void record_vertices(VkCommandBuffer cmd) const;
  void record_fluid(VkCommandBuffer cmd, uint32_t group) const;

 private:
  struct FluidGroup {
    std::shared_ptr<compute::TypedBuffer> depth, thickness;
    std::shared_ptr<compute::ComputePass> splat, smooth_rows, smooth_columns, shade;
  };
  std::shared_ptr<gpu::Context> ctx_;
  const RenderModel& model_;
  uint64_t generation_;
  BufferMap& internal_;
  BufferMap bound_;
  bool has_fluid_ = false;
  std::shared_ptr<compute::ComputePass> vertices_;
  std::vector<FluidGroup> fluid_;  // per camera group (empty passes where it has none)
};

}  // namespace cressim::render
