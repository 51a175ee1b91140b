#include "gpu/readback_batch.h"

#include <cstring>
#include <stdexcept>

#include "gpu/commands.h"

namespace cressim::gpu {

void readback_batch(Context& ctx, const std::vector<ReadbackItem>& items) {
  std::vector<VkDeviceSize> offsets(items.size(), 0);
  VkDeviceSize total = 0;
  for (size_t i = 0; i < items.size(); ++i) {
    const auto& it = items[i];
    if (it.size > it.src->size) throw std::out_of_range("readback_batch: beyond the end of a buffer");
    if (it.src->mapped || it.size == 0) continue;
    offsets[i] = total;
    total += (it.size + 255) & ~VkDeviceSize(255);  // each copy's destination aligned
  }
  Buffer staging;
  if (total) {
    staging = create_buffer(ctx, total, {Memory::READBACK});
    submit_now(ctx, [&](VkCommandBuffer cmd) {
      for (size_t i = 0; i < items.size(); ++i) {
        const auto& it = items[i];
        if (it.src->mapped || it.size == 0) continue;
        VkBufferCopy region{0, offsets[i], it.size};
        vkCmdCopyBuffer(cmd, it.src->buffer, staging.buffer, 1, &region);
      }
    });
  }
  for (size_t i = 0; i < items.size(); ++i) {
    const auto& it = items[i];
    const void* from = it.src->mapped ? it.src->mapped : static_cast<const char*>(staging.mapped) + offsets[i];
    if (it.size) std::memcpy(it.dst, from, it.size);
  }
  if (total) destroy_buffer(ctx, staging);
}

}  // namespace cressim::gpu
