// Layered 2D images (one layer per camera) used as render targets, as plain structs.
#pragma once
#include <cstdint>

#include <vulkan/vulkan.h>

namespace cressim::gpu {

struct Context;

struct Image {
  VkImage image = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkImageView view = VK_NULL_HANDLE;  // 2D array view of all layers
  VkFormat format = VK_FORMAT_UNDEFINED;
  uint32_t width = 0, height = 0, layers = 0;
};

Image create_image(Context& ctx, VkFormat format, uint32_t width, uint32_t height, uint32_t layers,
                   VkImageUsageFlags usage);
void destroy_image(Context& ctx, Image& image);

VkImageAspectFlags aspect_of(VkFormat format);

// One layout transition of every layer, with the access scopes that usually go with it.
void image_barrier(VkCommandBuffer cmd, const Image& image, VkImageLayout from, VkImageLayout to);

}  // namespace cressim::gpu
