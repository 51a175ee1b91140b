#include "gpu/buffer.h"

#include <cstring>

#include "gpu/commands.h"
#include "gpu/context.h"
#include "gpu/error.h"

namespace cressim::gpu {
namespace {

int find_memory_type(const Context& ctx, uint32_t allowed, VkMemoryPropertyFlags want) {
  for (uint32_t i = 0; i < ctx.memory.memoryTypeCount; ++i)
    if ((allowed & (1u << i)) && (ctx.memory.memoryTypes[i].propertyFlags & want) == want) return int(i);
  return -1;
}

uint32_t choose_memory_type(const Context& ctx, uint32_t allowed, Memory kind) {
  const VkMemoryPropertyFlags host = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
  int t = -1;
  switch (kind) {
    case Memory::DEVICE:
      // on unified memory the device-local heap is host-visible: map it and skip staging copies
      if (ctx.unified_memory) t = find_memory_type(ctx, allowed, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT | host);
      if (t < 0) t = find_memory_type(ctx, allowed, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
      break;
    case Memory::READBACK:
      t = find_memory_type(ctx, allowed, host | VK_MEMORY_PROPERTY_HOST_CACHED_BIT);
      if (t < 0) t = find_memory_type(ctx, allowed, host);
      break;
    default:
      t = find_memory_type(ctx, allowed, host);
  }
  if (t < 0) t = find_memory_type(ctx, allowed, 0);
  if (t < 0) throw VulkanError(VK_ERROR_OUT_OF_DEVICE_MEMORY, "no memory type for buffer");
  return uint32_t(t);
}

}  // namespace

Buffer create_buffer(Context& ctx, VkDeviceSize size, const BufferOptions& options) {
  Buffer b;
  b.size = size;
  b.exportable = options.exportable && ctx.external_memory_fd;
  VkExternalMemoryBufferCreateInfo ext{VK_STRUCTURE_TYPE_EXTERNAL_MEMORY_BUFFER_CREATE_INFO};
  ext.handleTypes = VK_EXTERNAL_MEMORY_HANDLE_TYPE_OPAQUE_FD_BIT;
  VkBufferCreateInfo bi{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  bi.pNext = b.exportable ? &ext : nullptr;
  bi.size = size == 0 ? 4 : size;  // zero-sized buffers are invalid; keep empty tables bindable
  bi.usage = options.usage | VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT |
             VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  bi.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  check(vkCreateBuffer(ctx.device, &bi, nullptr, &b.buffer), "vkCreateBuffer");

  VkMemoryRequirements req;
  vkGetBufferMemoryRequirements(ctx.device, b.buffer, &req);
  uint32_t type = choose_memory_type(ctx, req.memoryTypeBits, options.memory);
  VkExportMemoryAllocateInfo export_info{VK_STRUCTURE_TYPE_EXPORT_MEMORY_ALLOCATE_INFO};
  export_info.handleTypes = VK_EXTERNAL_MEMORY_HANDLE_TYPE_OPAQUE_FD_BIT;
  VkMemoryDedicatedAllocateInfo dedicated{VK_STRUCTURE_TYPE_MEMORY_DEDICATED_ALLOCATE_INFO};
  dedicated.buffer = b.buffer;
  if (b.exportable) export_info.pNext = &dedicated;
  VkMemoryAllocateInfo ai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  ai.pNext = b.exportable ? &export_info : nullptr;
  ai.allocationSize = req.size;
  b.allocation_size = req.size;
  ai.memoryTypeIndex = type;
  VkResult r = vkAllocateMemory(ctx.device, &ai, nullptr, &b.memory);
  if (r != VK_SUCCESS) {
    vkDestroyBuffer(ctx.device, b.buffer, nullptr);
    check(r, ("vkAllocateMemory (" + std::to_string(size) + " bytes)").c_str());
  }
  check(vkBindBufferMemory(ctx.device, b.buffer, b.memory, 0), "vkBindBufferMemory");
  if (ctx.memory.memoryTypes[type].propertyFlags & VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT)
    check(vkMapMemory(ctx.device, b.memory, 0, VK_WHOLE_SIZE, 0, &b.mapped), "vkMapMemory");
  return b;
}

void destroy_buffer(Context& ctx, Buffer& b) {
  if (b.mapped) vkUnmapMemory(ctx.device, b.memory);
  if (b.buffer) vkDestroyBuffer(ctx.device, b.buffer, nullptr);
  if (b.memory) vkFreeMemory(ctx.device, b.memory, nullptr);
  b = Buffer{};
}

void upload(Context& ctx, Buffer& dst, const void* src, VkDeviceSize size, VkDeviceSize offset) {
  if (size == 0) return;
  if (offset + size > dst.size) throw std::out_of_range("upload beyond the end of the buffer");
  if (dst.mapped) {
    std::memcpy(static_cast<char*>(dst.mapped) + offset, src, size);
    return;
  }
  Buffer staging = create_buffer(ctx, size, {Memory::UPLOAD});
  std::memcpy(staging.mapped, src, size);
  submit_now(ctx, [&](VkCommandBuffer cmd) {
    VkBufferCopy region{0, offset, size};
    vkCmdCopyBuffer(cmd, staging.buffer, dst.buffer, 1, &region);
  });
  destroy_buffer(ctx, staging);
}

void readback(Context& ctx, const Buffer& src, void* dst, VkDeviceSize size, VkDeviceSize offset) {
  if (size == 0) return;
  if (offset + size > src.size) throw std::out_of_range("readback beyond the end of the buffer");
  if (src.mapped) {
    std::memcpy(dst, static_cast<const char*>(src.mapped) + offset, size);
    return;
  }
  Buffer staging = create_buffer(ctx, size, {Memory::READBACK});
  submit_now(ctx, [&](VkCommandBuffer cmd) {
    VkBufferCopy region{offset, 0, size};
    vkCmdCopyBuffer(cmd, src.buffer, staging.buffer, 1, &region);
  });
  std::memcpy(dst, staging.mapped, size);
  destroy_buffer(ctx, staging);
}

void fill(Context& ctx, Buffer& dst, uint32_t value) {
  submit_now(ctx, [&](VkCommandBuffer cmd) { vkCmdFillBuffer(cmd, dst.buffer, 0, VK_WHOLE_SIZE, value); });
}

int export_memory_fd(Context& ctx, const Buffer& buffer) {
  if (!buffer.exportable) throw VulkanError(VK_ERROR_FEATURE_NOT_PRESENT, "buffer was not allocated exportable");
  auto get_fd = reinterpret_cast<PFN_vkGetMemoryFdKHR>(vkGetDeviceProcAddr(ctx.device, "vkGetMemoryFdKHR"));
  VkMemoryGetFdInfoKHR info{VK_STRUCTURE_TYPE_MEMORY_GET_FD_INFO_KHR};
  info.memory = buffer.memory;
  info.handleType = VK_EXTERNAL_MEMORY_HANDLE_TYPE_OPAQUE_FD_BIT;
  int fd = -1;
  check(get_fd(ctx.device, &info, &fd), "vkGetMemoryFdKHR");
  return fd;
}

OwnedBuffer::OwnedBuffer(std::shared_ptr<Context> c, VkDeviceSize size, const BufferOptions& options)
    : ctx(std::move(c)), buffer(create_buffer(*ctx, size, options)) {}

OwnedBuffer::~OwnedBuffer() { destroy_buffer(*ctx, buffer); }

}  // namespace cressim::gpu
