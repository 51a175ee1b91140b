#include "gpu/pipeline.h"

#include <cinttypes>
#include <cstdio>

#include "gpu/context.h"
#include "gpu/error.h"

namespace cressim::gpu {

namespace {

// What the driver reports of a compiled pipeline (CRESSIM_PIPELINE_STATISTICS=1: created with
// VK_PIPELINE_CREATE_CAPTURE_STATISTICS_BIT_KHR), a line to stderr.
void log_statistics(Context& ctx, VkPipeline pipeline, const std::string& name) {
  auto statistics = reinterpret_cast<PFN_vkGetPipelineExecutableStatisticsKHR>(
      vkGetDeviceProcAddr(ctx.device, "vkGetPipelineExecutableStatisticsKHR"));
  if (!statistics) return;
  VkPipelineExecutableInfoKHR info{VK_STRUCTURE_TYPE_PIPELINE_EXECUTABLE_INFO_KHR};
  info.pipeline = pipeline;
  uint32_t n = 0;
  if (statistics(ctx.device, &info, &n, nullptr) != VK_SUCCESS) return;
  std::vector<VkPipelineExecutableStatisticKHR> stats(n, {VK_STRUCTURE_TYPE_PIPELINE_EXECUTABLE_STATISTIC_KHR});
  if (statistics(ctx.device, &info, &n, stats.data()) != VK_SUCCESS) return;
  std::string line = "cressim: pipeline " + name + ":";
  for (const auto& s : stats) {
    char value[64];
    switch (s.format) {
      case VK_PIPELINE_EXECUTABLE_STATISTIC_FORMAT_BOOL32_KHR: std::snprintf(value, sizeof value, "%u", s.value.b32); break;
      case VK_PIPELINE_EXECUTABLE_STATISTIC_FORMAT_INT64_KHR: std::snprintf(value, sizeof value, "%" PRId64, s.value.i64); break;
      case VK_PIPELINE_EXECUTABLE_STATISTIC_FORMAT_UINT64_KHR: std::snprintf(value, sizeof value, "%" PRIu64, s.value.u64); break;
      default: std::snprintf(value, sizeof value, "%g", s.value.f64);
    }
    line += std::string(" ") + s.name + "=" + value + ";";
  }
  std::fprintf(stderr, "%s\n", line.c_str());
}

}  // namespace

void create_layout_and_set(Context& ctx, ComputePipeline& p, VkShaderStageFlags stages) {
  std::vector<VkDescriptorSetLayoutBinding> bindings;
  for (const auto& b : p.reflection.bindings) {
    VkDescriptorSetLayoutBinding lb{};
    lb.binding = b.binding;
    lb.descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    lb.descriptorCount = 1;
    lb.stageFlags = stages;
    bindings.push_back(lb);
  }
  VkDescriptorSetLayoutCreateInfo li{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  li.bindingCount = uint32_t(bindings.size());
  li.pBindings = bindings.data();
  check(vkCreateDescriptorSetLayout(ctx.device, &li, nullptr, &p.set_layout), "vkCreateDescriptorSetLayout");

  VkPushConstantRange range{stages, 0, p.reflection.push_constant_size};
  VkPipelineLayoutCreateInfo pli{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  pli.setLayoutCount = 1;
  pli.pSetLayouts = &p.set_layout;
  pli.pushConstantRangeCount = range.size ? 1 : 0;
  pli.pPushConstantRanges = &range;
  check(vkCreatePipelineLayout(ctx.device, &pli, nullptr, &p.layout), "vkCreatePipelineLayout");

  if (bindings.empty()) return;
  VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, uint32_t(bindings.size())};
  VkDescriptorPoolCreateInfo dpi{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  dpi.maxSets = 1;
  dpi.poolSizeCount = 1;
  dpi.pPoolSizes = &size;
  check(vkCreateDescriptorPool(ctx.device, &dpi, nullptr, &p.pool), "vkCreateDescriptorPool");
  VkDescriptorSetAllocateInfo ai{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  ai.descriptorPool = p.pool;
  ai.descriptorSetCount = 1;
  ai.pSetLayouts = &p.set_layout;
  check(vkAllocateDescriptorSets(ctx.device, &ai, &p.set), "vkAllocateDescriptorSets");
}

ComputePipeline create_compute_pipeline(Context& ctx, const std::vector<uint32_t>& spirv, const std::string& entry,
                                        const std::string& name) {
  ComputePipeline p;
  p.reflection = reflect_spirv(spirv);
  for (const auto& b : p.reflection.bindings)
    if (b.set != 0)
      throw VulkanError(VK_ERROR_INITIALIZATION_FAILED,
                        name + ": binding '" + b.name + "' is in descriptor set " + std::to_string(b.set) +
                            "; compute passes use set 0 only");
  if (const uint32_t limit = ctx.properties.limits.maxComputeSharedMemorySize; p.reflection.workgroup_bytes > limit)
    throw VulkanError(VK_ERROR_INITIALIZATION_FAILED,
                      name + ": its groupshared variables take " + std::to_string(p.reflection.workgroup_bytes) +
                          " bytes; this device allows a workgroup " + std::to_string(limit) +
                          " (maxComputeSharedMemorySize)");

  VkShaderModuleCreateInfo mi{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
  mi.codeSize = spirv.size() * 4;
  mi.pCode = spirv.data();
  check(vkCreateShaderModule(ctx.device, &mi, nullptr, &p.module), ("vkCreateShaderModule " + name).c_str());

  create_layout_and_set(ctx, p, VK_SHADER_STAGE_COMPUTE_BIT);

  VkComputePipelineCreateInfo ci{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
  ci.stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
  ci.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  ci.stage.module = p.module;
  ci.stage.pName = entry.c_str();
  ci.layout = p.layout;
  if (ctx.pipeline_statistics) ci.flags |= VK_PIPELINE_CREATE_CAPTURE_STATISTICS_BIT_KHR;
  check(vkCreateComputePipelines(ctx.device, VK_NULL_HANDLE, 1, &ci, nullptr, &p.pipeline),
        ("vkCreateComputePipelines " + name).c_str());
  if (ctx.pipeline_statistics) log_statistics(ctx, p.pipeline, name);
  return p;
}

void destroy_compute_pipeline(Context& ctx, ComputePipeline& p) {
  if (p.pool) vkDestroyDescriptorPool(ctx.device, p.pool, nullptr);
  if (p.pipeline) vkDestroyPipeline(ctx.device, p.pipeline, nullptr);
  if (p.layout) vkDestroyPipelineLayout(ctx.device, p.layout, nullptr);
  if (p.set_layout) vkDestroyDescriptorSetLayout(ctx.device, p.set_layout, nullptr);
  if (p.module) vkDestroyShaderModule(ctx.device, p.module, nullptr);
  p = ComputePipeline{};
}

void bind_buffer(Context& ctx, ComputePipeline& p, uint32_t binding, VkBuffer buffer) {
  VkDescriptorBufferInfo info{buffer, 0, VK_WHOLE_SIZE};
  VkWriteDescriptorSet w{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
  w.dstSet = p.set;
  w.dstBinding = binding;
  w.descriptorCount = 1;
  w.descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  w.pBufferInfo = &info;
  vkUpdateDescriptorSets(ctx.device, 1, &w, 0, nullptr);
}

void record_dispatch(VkCommandBuffer cmd, const ComputePipeline& p, const void* push_constants,
                     const uint32_t groups[3]) {
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.pipeline);
  if (p.set) vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.layout, 0, 1, &p.set, 0, nullptr);
  if (p.reflection.push_constant_size && push_constants)
    vkCmdPushConstants(cmd, p.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, p.reflection.push_constant_size, push_constants);
  if (groups[0] && groups[1] && groups[2]) vkCmdDispatch(cmd, groups[0], groups[1], groups[2]);
}

}  // namespace cressim::gpu
