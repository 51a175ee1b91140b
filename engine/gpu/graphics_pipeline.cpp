#include "gpu/graphics_pipeline.h"

#include <algorithm>

#include "gpu/context.h"
#include "gpu/error.h"

namespace cressim::gpu {

ComputePipeline create_graphics_pipeline(Context& ctx, const GraphicsPipelineDesc& desc) {
  ComputePipeline p;
  // one binding table for both stages (the same name at the same binding in each)
  ShaderReflection vr = reflect_spirv(*desc.vertex), fr = reflect_spirv(*desc.fragment);
  p.reflection = vr;
  for (const auto& b : fr.bindings)
    if (!p.reflection.find_binding(b.name)) p.reflection.bindings.push_back(b);
  for (const auto& c : fr.constants)
    if (!p.reflection.find_constant(c.name)) p.reflection.constants.push_back(c);
  p.reflection.push_constant_size = std::max(vr.push_constant_size, fr.push_constant_size);

  VkShaderModule modules[2];
  const std::vector<uint32_t>* code[2] = {desc.vertex, desc.fragment};
  for (int i = 0; i < 2; ++i) {
    VkShaderModuleCreateInfo mi{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
    mi.codeSize = code[i]->size() * 4;
    mi.pCode = code[i]->data();
    check(vkCreateShaderModule(ctx.device, &mi, nullptr, &modules[i]), ("vkCreateShaderModule " + desc.name).c_str());
  }
  p.module = modules[0];

  create_layout_and_set(ctx, p, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT);

  VkPipelineShaderStageCreateInfo st[2]{};
  for (int i = 0; i < 2; ++i) {
    st[i].sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
    st[i].stage = i == 0 ? VK_SHADER_STAGE_VERTEX_BIT : VK_SHADER_STAGE_FRAGMENT_BIT;
    st[i].module = modules[i];
    st[i].pName = "main";
  }
  VkPipelineVertexInputStateCreateInfo vin{VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO};
  VkPipelineInputAssemblyStateCreateInfo ia{VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO};
  ia.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
  VkPipelineViewportStateCreateInfo vp{VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO};
  vp.viewportCount = 1;
  vp.scissorCount = 1;
  VkPipelineRasterizationStateCreateInfo rs{VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO};
  rs.polygonMode = VK_POLYGON_MODE_FILL;
  rs.cullMode = VK_CULL_MODE_NONE;  // meshes of either winding; depth test resolves visibility
  rs.lineWidth = 1.0f;
  VkPipelineMultisampleStateCreateInfo ms{VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO};
  ms.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
  VkPipelineDepthStencilStateCreateInfo ds{VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO};
  ds.depthTestEnable = desc.depth_format != VK_FORMAT_UNDEFINED;
  ds.depthWriteEnable = ds.depthTestEnable;
  ds.depthCompareOp = VK_COMPARE_OP_LESS;
  std::vector<VkPipelineColorBlendAttachmentState> blend(desc.color_formats.size());
  for (auto& b : blend) b.colorWriteMask = 0xf;
  VkPipelineColorBlendStateCreateInfo cb{VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO};
  cb.attachmentCount = uint32_t(blend.size());
  cb.pAttachments = blend.data();
  VkDynamicState dyn[] = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
  VkPipelineDynamicStateCreateInfo dy{VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO};
  dy.dynamicStateCount = 2;
  dy.pDynamicStates = dyn;
  VkPipelineRenderingCreateInfo ri{VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO};
  ri.colorAttachmentCount = uint32_t(desc.color_formats.size());
  ri.pColorAttachmentFormats = desc.color_formats.data();
  ri.depthAttachmentFormat = desc.depth_format;
  VkGraphicsPipelineCreateInfo gi{VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO};
  gi.pNext = &ri;
  gi.stageCount = 2;
  gi.pStages = st;
  gi.pVertexInputState = &vin;
  gi.pInputAssemblyState = &ia;
  gi.pViewportState = &vp;
  gi.pRasterizationState = &rs;
  gi.pMultisampleState = &ms;
  gi.pDepthStencilState = &ds;
  gi.pColorBlendState = &cb;
  gi.pDynamicState = &dy;
  gi.layout = p.layout;
  VkResult r = vkCreateGraphicsPipelines(ctx.device, VK_NULL_HANDLE, 1, &gi, nullptr, &p.pipeline);
  vkDestroyShaderModule(ctx.device, modules[1], nullptr);
  check(r, ("vkCreateGraphicsPipelines " + desc.name).c_str());

  return p;
}

}  // namespace cressim::gpu
