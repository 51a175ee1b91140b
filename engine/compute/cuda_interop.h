// Vulkan memory and timeline semaphores imported into CUDA with the driver API, loaded at run
// time (dlopen libcuda.so.1): no CUDA toolkit at build time, and machines without an NVIDIA
// driver simply report "unavailable".
#pragma once
#include <cstdint>
#include <memory>
#include <string>

namespace cressim::gpu { struct Buffer; struct Context; struct Timeline; }

namespace cressim::compute {

// A buffer's memory as a CUDA device pointer; unmapped when the last holder lets go.
struct CudaMapping {
  uint64_t pointer = 0;
  int device = -1;  // CUDA ordinal
  void* external_memory = nullptr;
  ~CudaMapping();
};

// The engine's timeline semaphore seen from CUDA, to order a CUDA stream against the frame.
struct CudaTimeline {
  void* external_semaphore = nullptr;
  int device = -1;
  ~CudaTimeline();
  void signal(uint64_t value, uintptr_t stream) const;  // on `stream`, after its prior work
};

// Waits on the host for the work queued on a CUDA stream.
void synchronize_cuda_stream(int device, uintptr_t stream);

// Why CUDA interop is not available ("" when it is) for this Vulkan device.
std::string cuda_unavailable_reason(const gpu::Context& ctx);
// The CUDA ordinal of the Vulkan device (by UUID); throws if none.
int cuda_device_of(const gpu::Context& ctx);

std::shared_ptr<CudaMapping> map_to_cuda(gpu::Context& ctx, const gpu::Buffer& buffer);
std::shared_ptr<CudaTimeline> import_timeline(gpu::Context& ctx, const gpu::Timeline& timeline);

}  // namespace cressim::compute
