// Graphics pipelines for dynamic rendering: vertex + fragment SPIR-V, bindings reflected from
// both stages (vertices are pulled from storage buffers: no vertex input state).
#pragma once
#include <string>
#include <vector>

#include <vulkan/vulkan.h>

#include "gpu/pipeline.h"

namespace cressim::gpu {

struct Context;

struct GraphicsPipelineDesc {
  std::string name;
  const std::vector<uint32_t>* vertex = nullptr;
  const std::vector<uint32_t>* fragment = nullptr;
  std::vector<VkFormat> color_formats;
  VkFormat depth_format = VK_FORMAT_UNDEFINED;
};

// Shares ComputePipeline's layout, descriptor set and reflection; `pipeline` is graphics.
ComputePipeline create_graphics_pipeline(Context& ctx, const GraphicsPipelineDesc& desc);

}  // namespace cressim::gpu
