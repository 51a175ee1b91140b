// The Vulkan instance, the chosen device and its one compute queue.
#pragma once
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <vulkan/vulkan.h>

namespace cressim::gpu {

struct DeviceInfo {
  uint32_t index = 0;
  std::string name;
  std::string type;  // "discrete", "integrated", "virtual", "cpu", "other"
  uint32_t api_version = 0;
  std::string driver;
  std::string uuid;  // 32 hex digits: the CUDA device of the same GPU has the same (cuDeviceGetUuid)
};

struct ContextOptions {
  bool validation = false;  // VK_LAYER_KHRONOS_validation + a messenger that collects messages
  std::string device;       // index or name substring; empty: CRESSIM_DEVICE or the best device
  bool pipeline_statistics = false;  // log each compute pipeline's compiled statistics (registers, ...)
};

struct Context {
  VkInstance instance = VK_NULL_HANDLE;
  VkPhysicalDevice physical = VK_NULL_HANDLE;
  VkDevice device = VK_NULL_HANDLE;
  VkQueue queue = VK_NULL_HANDLE;
  uint32_t queue_family = 0;
  VkCommandPool command_pool = VK_NULL_HANDLE;
  VkDebugUtilsMessengerEXT messenger = VK_NULL_HANDLE;

  DeviceInfo info;
  VkPhysicalDeviceProperties properties{};
  VkPhysicalDeviceMemoryProperties memory{};
  uint32_t subgroup_size = 0;
  uint8_t device_uuid[VK_UUID_SIZE]{};  // matches the CUDA device of the same GPU
  bool validation = false;
  bool unified_memory = false;  // CPU/integrated device: device-local memory is host-visible
  bool external_memory_fd = false;
  bool external_semaphore_fd = false;
  bool pipeline_statistics = false;  // VK_KHR_pipeline_executable_properties on and asked for

  // Validation messages (warnings and errors) collected since creation.
  std::mutex messages_mutex;
  std::vector<std::string> validation_messages;

  ~Context();
};

// Lists the physical devices the loader sees (for `cressim info` and CRESSIM_DEVICE).
std::vector<DeviceInfo> list_devices();

// Creates instance and device; the chosen device is logged once per process.
std::shared_ptr<Context> create_context(const ContextOptions& options = {});

// Environment switches: CRESSIM_VALIDATION=1, CRESSIM_DEVICE=<index|name substring>,
// CRESSIM_PIPELINE_STATISTICS=1 (what the driver reports of each compiled compute pipeline, to
// stderr: register counts and the like tell occupancy limits that GPU timings only hint at).
ContextOptions options_from_environment();

}  // namespace cressim::gpu
