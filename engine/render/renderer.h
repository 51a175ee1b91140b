// The batched rasterizer, graphics pipelines or (CRESSIM_RASTER=compute) compute passes that
// write the same buffers (raster_compute.comp.hlsl says why). Shadow maps first (per shadow group, one depth-only pass into
// layered targets, copied into "render.shadow_maps"), then per camera group one
// dynamic-rendering pass into layered targets (colour, metric depth, segmentation), then copies
// into typed buffers that passes and torch read ("camera{g}.rgb" (layers, H, W, 4) uint8, "camera{g}.depth" (layers, H, W) float32 in
// metres, 0 where nothing was hit, "camera{g}.segmentation" (layers, H, W) uint32, 0 background),
// those of the group's Camera.products. Instances outside their camera's frustum are culled
// first (culling.h): the graphics path draws the GPU-written list indirectly, the compute
// rasterizer skips them by the same test.
#pragma once
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "compute/compute_pass.h"
#include "compute/typed_buffer.h"
#include "gpu/image.h"
#include "gpu/pipeline.h"
#include "render/particle_draw.h"
#include "render/culling.h"
#include "render/render_model.h"

namespace cressim::render {

using BufferMap = compute::BufferMap;

class Renderer {
 public:
  // internal: receives the renderer's buffers; scene: the engine's transform buffers
  Renderer(std::shared_ptr<gpu::Context> ctx, RenderModel model, uint64_t generation, BufferMap& internal,
           const BufferMap& scene);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  void record(VkCommandBuffer cmd) const;
  const RenderModel& model() const { return model_; }
  bool compute() const { return !compute_passes_.empty(); }

 private:
  void record_shadows(VkCommandBuffer cmd) const;
  struct Targets {
    gpu::Image color, depth, segmentation, z_buffer;
    std::shared_ptr<compute::TypedBuffer> rgb_out, depth_out, segmentation_out;
    std::shared_ptr<compute::TypedBuffer> scene_depth;  // depth_out, or a stand-in the fluid passes need
  };
  std::shared_ptr<gpu::Context> ctx_;
  RenderModel model_;
  gpu::ComputePipeline pipeline_;  // a graphics pipeline (same layout/descriptor struct)
  gpu::ComputePipeline shadow_pipeline_;  // depth only; exists when some env has shadows
  std::unique_ptr<gpu::OwnedBuffer> indices_;
  std::vector<Targets> targets_;
  std::vector<gpu::Image> shadow_targets_;  // per shadow group
  std::vector<std::shared_ptr<compute::ComputePass>> compute_passes_;  // per camera group, compute mode
  struct VertexSource {  // a mesh whose positions are copied from an engine buffer every frame
    std::shared_ptr<compute::TypedBuffer> from;
    VkBufferCopy region;
  };
  std::vector<VertexSource> vertex_sources_;
  VkBuffer vertex_positions_ = VK_NULL_HANDLE;
  std::shared_ptr<compute::TypedBuffer> shadow_maps_;
  std::unique_ptr<ParticleDraw> particles_;
  std::unique_ptr<Culling> culling_;  // counts in both modes; the draw list in the graphics path
  bool indirect_ = false;             // the graphics path draws the culled list
  bool multi_draw_ = false;           // in one vkCmdDrawIndexedIndirect per group
};

}  // namespace cressim::render
