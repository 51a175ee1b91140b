// GPU buffers as plain structs with free functions.
#pragma once
#include <cstddef>
#include <memory>

#include <vulkan/vulkan.h>

namespace cressim::gpu {

struct Context;

enum class Memory {
  NONE = 0,
  DEVICE,    // fastest for the GPU; host-visible too on unified-memory devices (lavapipe)
  UPLOAD,    // host-visible, coherent: host writes, GPU reads
  READBACK,  // host-visible, cached where possible: GPU writes, host reads
};

struct Buffer {
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkDeviceSize size = 0;
  void* mapped = nullptr;  // non-null when the host can see the memory without a copy
  bool exportable = false;
  VkDeviceSize allocation_size = 0;  // of the memory object (what an importer must be told)
};

struct BufferOptions {
  Memory memory = Memory::DEVICE;
  VkBufferUsageFlags usage = 0;  // added to storage + transfer src/dst
  bool exportable = false;       // allocate with an exportable OPAQUE_FD handle (CUDA interop)
};

Buffer create_buffer(Context& ctx, VkDeviceSize size, const BufferOptions& options = {});
void destroy_buffer(Context& ctx, Buffer& buffer);

// Host <-> buffer copies: a memcpy when mapped, otherwise through a staging buffer and a
// one-off submit. Not for the per-step path.
void upload(Context& ctx, Buffer& dst, const void* src, VkDeviceSize size, VkDeviceSize offset = 0);
void readback(Context& ctx, const Buffer& src, void* dst, VkDeviceSize size, VkDeviceSize offset = 0);
void fill(Context& ctx, Buffer& dst, uint32_t value);

// An OPAQUE_FD handle to an exportable buffer's memory (the caller owns the fd).
int export_memory_fd(Context& ctx, const Buffer& buffer);

// A buffer owned by a shared_ptr that keeps its Context alive (used for views handed to Python).
struct OwnedBuffer {
  std::shared_ptr<Context> ctx;
  Buffer buffer;
  OwnedBuffer(std::shared_ptr<Context> c, VkDeviceSize size, const BufferOptions& options);
  ~OwnedBuffer();
  OwnedBuffer(const OwnedBuffer&) = delete;
  OwnedBuffer& operator=(const OwnedBuffer&) = delete;
};

}  // namespace cressim::gpu
