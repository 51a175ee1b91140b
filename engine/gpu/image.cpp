#include "gpu/image.h"

#include "gpu/context.h"
#include "gpu/error.h"

namespace cressim::gpu {

VkImageAspectFlags aspect_of(VkFormat format) {
  switch (format) {
    case VK_FORMAT_D32_SFLOAT:
    case VK_FORMAT_D16_UNORM: return VK_IMAGE_ASPECT_DEPTH_BIT;
    default: return VK_IMAGE_ASPECT_COLOR_BIT;
  }
}

Image create_image(Context& ctx, VkFormat format, uint32_t width, uint32_t height, uint32_t layers,
                   VkImageUsageFlags usage) {
  Image im;
  im.format = format;
  im.width = width;
  im.height = height;
  im.layers = layers;
  VkImageCreateInfo ci{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
  ci.imageType = VK_IMAGE_TYPE_2D;
  ci.format = format;
  ci.extent = {width, height, 1};
  ci.mipLevels = 1;
  ci.arrayLayers = layers;
  ci.samples = VK_SAMPLE_COUNT_1_BIT;
  ci.tiling = VK_IMAGE_TILING_OPTIMAL;
  ci.usage = usage;
  ci.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  check(vkCreateImage(ctx.device, &ci, nullptr, &im.image), "vkCreateImage");
  VkMemoryRequirements req;
  vkGetImageMemoryRequirements(ctx.device, im.image, &req);
  int type = -1;
  for (uint32_t i = 0; i < ctx.memory.memoryTypeCount && type < 0; ++i)
    if ((req.memoryTypeBits & (1u << i)) &&
        (ctx.memory.memoryTypes[i].propertyFlags & VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT))
      type = int(i);
  for (uint32_t i = 0; i < ctx.memory.memoryTypeCount && type < 0; ++i)
    if (req.memoryTypeBits & (1u << i)) type = int(i);
  VkMemoryAllocateInfo ai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  ai.allocationSize = req.size;
  ai.memoryTypeIndex = uint32_t(type);
  check(vkAllocateMemory(ctx.device, &ai, nullptr, &im.memory), "vkAllocateMemory(image)");
  check(vkBindImageMemory(ctx.device, im.image, im.memory, 0), "vkBindImageMemory");
  VkImageViewCreateInfo vi{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
  vi.image = im.image;
  vi.viewType = VK_IMAGE_VIEW_TYPE_2D_ARRAY;
  vi.format = format;
  vi.subresourceRange = {aspect_of(format), 0, 1, 0, layers};
  check(vkCreateImageView(ctx.device, &vi, nullptr, &im.view), "vkCreateImageView");
  return im;
}

void destroy_image(Context& ctx, Image& im) {
  if (im.view) vkDestroyImageView(ctx.device, im.view, nullptr);
  if (im.image) vkDestroyImage(ctx.device, im.image, nullptr);
  if (im.memory) vkFreeMemory(ctx.device, im.memory, nullptr);
  im = Image{};
}

void image_barrier(VkCommandBuffer cmd, const Image& im, VkImageLayout from, VkImageLayout to) {
  VkImageMemoryBarrier2 b{VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2};
  b.srcStageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
  b.srcAccessMask = VK_ACCESS_2_MEMORY_WRITE_BIT;
  b.dstStageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
  b.dstAccessMask = VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT;
  b.oldLayout = from;
  b.newLayout = to;
  b.srcQueueFamilyIndex = b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.image = im.image;
  b.subresourceRange = {aspect_of(im.format), 0, 1, 0, im.layers};
  VkDependencyInfo di{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
  di.imageMemoryBarrierCount = 1;
  di.pImageMemoryBarriers = &b;
  vkCmdPipelineBarrier2(cmd, &di);
}

}  // namespace cressim::gpu
