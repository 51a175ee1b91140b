// Compute pipelines whose descriptor layout and push-constant range come from SPIR-V reflection.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <vulkan/vulkan.h>

#include "gpu/spirv_reflect.h"

namespace cressim::gpu {

struct Context;

struct ComputePipeline {
  VkShaderModule module = VK_NULL_HANDLE;
  VkDescriptorSetLayout set_layout = VK_NULL_HANDLE;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkPipeline pipeline = VK_NULL_HANDLE;
  VkDescriptorPool pool = VK_NULL_HANDLE;
  VkDescriptorSet set = VK_NULL_HANDLE;  // one set: every binding a storage buffer in set 0
  ShaderReflection reflection;
};

// The descriptor set layout (every reflected binding a storage buffer), the pipeline layout with
// the push-constant range, and the one descriptor set, for `stages`; p.reflection must be set.
void create_layout_and_set(Context& ctx, ComputePipeline& p, VkShaderStageFlags stages);

ComputePipeline create_compute_pipeline(Context& ctx, const std::vector<uint32_t>& spirv, const std::string& entry,
                                        const std::string& name);
void destroy_compute_pipeline(Context& ctx, ComputePipeline& p);

// Points binding `binding` of the pipeline's set at `buffer` (whole range).
void bind_buffer(Context& ctx, ComputePipeline& p, uint32_t binding, VkBuffer buffer);

// Records bind + push constants + dispatch of `groups` thread groups.
void record_dispatch(VkCommandBuffer cmd, const ComputePipeline& p, const void* push_constants,
                     const uint32_t groups[3]);

}  // namespace cressim::gpu
