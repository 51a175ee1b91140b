// Several device buffers to host memory in one submit: what a sensor frame's images need (every
// camera product of a frame at once, not one staging buffer and one wait per product).
#pragma once
#include <vector>

#include <vulkan/vulkan.h>

#include "gpu/buffer.h"

namespace cressim::gpu {

struct ReadbackItem {
  const Buffer* src;
  void* dst;
  VkDeviceSize size;  // bytes from the start of src
};

// One staging buffer for all items that are not host-visible, one submit copying into it, one
// wait, then a memcpy per item (host-visible items are copied directly).
void readback_batch(Context& ctx, const std::vector<ReadbackItem>& items);

}  // namespace cressim::gpu
