// Frustum culling and the graphics rasterizer's draw list (shaders/render/cull.comp.hlsl):
// every frame the draw commands' instance counts and the per-camera counts are reset, then a
// compute pass tests each (renderable, camera) instance's bounding sphere against its camera
// and appends the visible ones to their draw's range; the camera passes draw with
// vkCmdDrawIndexedIndirect from that list. "render.visible_counts" (cameras, 2) uint32 holds
// each camera's visible and culled instances of the last frame. CRESSIM_CULLING=0 keeps every
// instance (the same images; for comparisons).
#pragma once
#include <memory>
#include <vector>

#include "compute/compute_pass.h"
#include "compute/typed_buffer.h"
#include "render/render_model.h"

namespace cressim::render {

bool culling_enabled();  // CRESSIM_CULLING: unset or 1 on, 0 off

class Culling {
 public:
  // bound: the renderer's buffers by binding name (instances, renderables, cameras, transforms)
  Culling(std::shared_ptr<gpu::Context> ctx, const RenderModel& model, uint64_t generation, compute::BufferMap& internal,
          const compute::BufferMap& bound);

  void record(VkCommandBuffer cmd) const;  // ends with a barrier before the draws
  VkBuffer commands() const { return commands_->storage->buffer.buffer; }
  const std::shared_ptr<compute::TypedBuffer>& visible_instances() const { return visible_instances_; }
  uint32_t first_draw(size_t group) const { return first_draw_[group]; }

 private:
  std::shared_ptr<compute::TypedBuffer> commands_, visible_instances_, visible_counts_;
  std::unique_ptr<gpu::OwnedBuffer> template_;  // the commands with no instances
  std::shared_ptr<compute::ComputePass> pass_;
  std::vector<uint32_t> first_draw_;  // per group
  VkDeviceSize command_bytes_ = 0;
};

}  // namespace cressim::render
