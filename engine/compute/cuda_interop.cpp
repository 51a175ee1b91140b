#include "compute/cuda_interop.h"

#include <dlfcn.h>
#include <unistd.h>

#include <cstring>
#include <mutex>
#include <stdexcept>

#include "gpu/buffer.h"
#include "gpu/commands.h"
#include "gpu/context.h"

namespace cressim::compute {
namespace {

// The few CUDA driver API types and structs used here (ABI of cuda.h, CUDA 10+).
using CUresult = int;
using CUdevice = int;
using CUcontext = void*;
using CUdeviceptr = unsigned long long;
using CUstream = void*;
constexpr int kMemoryOpaqueFd = 1;     // CU_EXTERNAL_MEMORY_HANDLE_TYPE_OPAQUE_FD
constexpr int kTimelineOpaqueFd = 9;   // CU_EXTERNAL_SEMAPHORE_HANDLE_TYPE_TIMELINE_SEMAPHORE_FD

union Handle {
  int fd;
  struct {
    void* handle;
    const void* name;
  } win32;
  const void* sci;
};
struct MemoryHandleDesc {
  int type;
  Handle handle;
  unsigned long long size;
  unsigned int flags;
  unsigned int reserved[16];
};
struct BufferDesc {
  unsigned long long offset, size;
  unsigned int flags;
  unsigned int reserved[16];
};
struct SemaphoreHandleDesc {
  int type;
  Handle handle;
  unsigned int flags;
  unsigned int reserved[16];
};
struct SignalParams {
  struct {
    struct {
      unsigned long long value;
    } fence;
    union {
      void* fence;
      unsigned long long reserved;
    } sci;
    struct {
      unsigned long long key;
    } keyed_mutex;
    unsigned int reserved[12];
  } params;
  unsigned int flags;
  unsigned int reserved[16];
};

struct Driver {
  std::string error;
  CUresult (*cuInit)(unsigned);
  CUresult (*cuDeviceGetCount)(int*);
  CUresult (*cuDeviceGet)(CUdevice*, int);
  CUresult (*cuDeviceGetUuid)(unsigned char*, CUdevice);
  CUresult (*cuDevicePrimaryCtxRetain)(CUcontext*, CUdevice);
  CUresult (*cuCtxPushCurrent)(CUcontext);
  CUresult (*cuCtxPopCurrent)(CUcontext*);
  CUresult (*cuImportExternalMemory)(void**, const MemoryHandleDesc*);
  CUresult (*cuExternalMemoryGetMappedBuffer)(CUdeviceptr*, void*, const BufferDesc*);
  CUresult (*cuDestroyExternalMemory)(void*);
  CUresult (*cuMemFree)(CUdeviceptr);
  CUresult (*cuImportExternalSemaphore)(void**, const SemaphoreHandleDesc*);
  CUresult (*cuSignalExternalSemaphoresAsync)(void* const*, const SignalParams*, unsigned, CUstream);
  CUresult (*cuDestroyExternalSemaphore)(void*);
  CUresult (*cuStreamSynchronize)(CUstream);
  CUresult (*cuGetErrorString)(CUresult, const char**);
};

const Driver& driver() {
  static Driver d = [] {
    Driver d{};
    void* lib = dlopen("libcuda.so.1", RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
      d.error = "libcuda.so.1 is not installed (no NVIDIA driver)";
      return d;
    }
    auto load = [&](auto& fn, const char* name) {
      fn = reinterpret_cast<std::remove_reference_t<decltype(fn)>>(dlsym(lib, name));
      if (!fn && d.error.empty()) d.error = std::string("libcuda lacks ") + name;
    };
    load(d.cuInit, "cuInit");
    load(d.cuDeviceGetCount, "cuDeviceGetCount");
    load(d.cuDeviceGet, "cuDeviceGet");
    load(d.cuDeviceGetUuid, "cuDeviceGetUuid");
    load(d.cuDevicePrimaryCtxRetain, "cuDevicePrimaryCtxRetain");
    load(d.cuCtxPushCurrent, "cuCtxPushCurrent_v2");
    load(d.cuCtxPopCurrent, "cuCtxPopCurrent_v2");
    load(d.cuImportExternalMemory, "cuImportExternalMemory");
    load(d.cuExternalMemoryGetMappedBuffer, "cuExternalMemoryGetMappedBuffer");
    load(d.cuDestroyExternalMemory, "cuDestroyExternalMemory");
    load(d.cuMemFree, "cuMemFree_v2");
    load(d.cuImportExternalSemaphore, "cuImportExternalSemaphore");
    load(d.cuSignalExternalSemaphoresAsync, "cuSignalExternalSemaphoresAsync");
    load(d.cuDestroyExternalSemaphore, "cuDestroyExternalSemaphore");
    load(d.cuStreamSynchronize, "cuStreamSynchronize");
    load(d.cuGetErrorString, "cuGetErrorString");
    if (d.error.empty() && d.cuInit(0) != 0) d.error = "cuInit failed (no usable NVIDIA GPU)";
    return d;
  }();
  return d;
}

void check_cu(CUresult r, const char* what) {
  if (r == 0) return;
  const char* msg = "unknown";
  if (driver().cuGetErrorString) driver().cuGetErrorString(r, &msg);
  throw std::runtime_error(std::string(what) + " failed: " + msg + " (" + std::to_string(r) + ")");
}

// the device's primary context (the one torch uses), retained once per device for the process
CUcontext primary_context(int device) {
  static std::mutex mutex;
  static CUcontext contexts[64] = {};
  std::lock_guard<std::mutex> lock(mutex);
  if (device < 0 || device >= 64) throw std::runtime_error("CUDA device ordinal out of range");
  if (!contexts[device]) {
    CUdevice dev;
    check_cu(driver().cuDeviceGet(&dev, device), "cuDeviceGet");
    check_cu(driver().cuDevicePrimaryCtxRetain(&contexts[device], dev), "cuDevicePrimaryCtxRetain");
  }
  return contexts[device];
}

// runs f with the device's primary context current
template <class F>
void with_context(int device, F f) {
  const Driver& d = driver();
  CUcontext ctx = primary_context(device);
  check_cu(d.cuCtxPushCurrent(ctx), "cuCtxPushCurrent");
  try {
    f();
  } catch (...) {
    d.cuCtxPopCurrent(&ctx);
    throw;
  }
  d.cuCtxPopCurrent(&ctx);
}

}  // namespace

std::string cuda_unavailable_reason(const gpu::Context& ctx) {
  if (ctx.unified_memory) return "the Vulkan device's memory is host-visible (CPU tensors are zero-copy instead)";
  if (!ctx.external_memory_fd) return "the Vulkan device lacks VK_KHR_external_memory_fd";
  if (!driver().error.empty()) return driver().error;
  try {
    cuda_device_of(ctx);
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

int cuda_device_of(const gpu::Context& ctx) {
  const Driver& d = driver();
  if (!d.error.empty()) throw std::runtime_error(d.error);
  int n = 0;
  check_cu(d.cuDeviceGetCount(&n), "cuDeviceGetCount");
  for (int i = 0; i < n; ++i) {
    CUdevice dev;
    unsigned char uuid[16];
    check_cu(d.cuDeviceGet(&dev, i), "cuDeviceGet");
    check_cu(d.cuDeviceGetUuid(uuid, dev), "cuDeviceGetUuid");
    if (std::memcmp(uuid, ctx.device_uuid, 16) == 0) return i;
  }
  throw std::runtime_error("no CUDA device has the UUID of Vulkan device '" + ctx.info.name + "'");
}

CudaMapping::~CudaMapping() {
  const Driver& d = driver();
  if (!external_memory) return;
  try {
    with_context(device, [&] {
      d.cuMemFree(pointer);
      d.cuDestroyExternalMemory(external_memory);
    });
  } catch (...) {
  }
}

std::shared_ptr<CudaMapping> map_to_cuda(gpu::Context& ctx, const gpu::Buffer& buffer) {
  const std::string why = cuda_unavailable_reason(ctx);
  if (!why.empty()) throw std::runtime_error("CUDA zero-copy is unavailable: " + why);
  auto m = std::make_shared<CudaMapping>();
  m->device = cuda_device_of(ctx);
  const int fd = gpu::export_memory_fd(ctx, buffer);
  with_context(m->device, [&] {
    MemoryHandleDesc desc{};
    desc.type = kMemoryOpaqueFd;
    desc.handle.fd = fd;
    desc.size = buffer.allocation_size;
    CUresult r = driver().cuImportExternalMemory(&m->external_memory, &desc);
    if (r != 0) close(fd);  // on success CUDA owns the fd
    check_cu(r, "cuImportExternalMemory");
    BufferDesc bd{};
    bd.size = buffer.size;
    CUdeviceptr pointer = 0;
    check_cu(driver().cuExternalMemoryGetMappedBuffer(&pointer, m->external_memory, &bd),
             "cuExternalMemoryGetMappedBuffer");
    m->pointer = pointer;
  });
  return m;
}

CudaTimeline::~CudaTimeline() {
  if (external_semaphore) driver().cuDestroyExternalSemaphore(external_semaphore);
}

void CudaTimeline::signal(uint64_t value, uintptr_t stream) const {
  SignalParams p{};
  p.params.fence.value = value;
  with_context(device, [&] {
    check_cu(driver().cuSignalExternalSemaphoresAsync(&external_semaphore, &p, 1, reinterpret_cast<CUstream>(stream)),
             "cuSignalExternalSemaphoresAsync");
  });
}

void synchronize_cuda_stream(int device, uintptr_t stream) {
  with_context(device, [&] {
    check_cu(driver().cuStreamSynchronize(reinterpret_cast<CUstream>(stream)), "cuStreamSynchronize");
  });
}

std::shared_ptr<CudaTimeline> import_timeline(gpu::Context& ctx, const gpu::Timeline& timeline) {
  if (!ctx.external_semaphore_fd) throw std::runtime_error("the Vulkan device lacks VK_KHR_external_semaphore_fd");
  auto t = std::make_shared<CudaTimeline>();
  t->device = cuda_device_of(ctx);
  const int fd = gpu::export_semaphore_fd(ctx, timeline);
  with_context(t->device, [&] {
    SemaphoreHandleDesc desc{};
    desc.type = kTimelineOpaqueFd;
    desc.handle.fd = fd;
    CUresult r = driver().cuImportExternalSemaphore(&t->external_semaphore, &desc);
    if (r != 0) close(fd);
    check_cu(r, "cuImportExternalSemaphore");
  });
  return t;
}

}  // namespace cressim::compute
