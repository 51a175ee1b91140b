#include "gpu/context.h"

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>

#include "gpu/error.h"

namespace cressim::gpu {
namespace {

const char* kValidationLayer = "VK_LAYER_KHRONOS_validation";

std::string type_name(VkPhysicalDeviceType t) {
  switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return "discrete";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return "integrated";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return "virtual";
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return "cpu";
    default: return "other";
  }
}

// Lower is better: discrete, then integrated, then virtual, then CPU (lavapipe).
int type_rank(VkPhysicalDeviceType t) {
  switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return 0;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return 1;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return 3;
    default: return 4;
  }
}

VKAPI_ATTR VkBool32 VKAPI_CALL on_validation_message(
    VkDebugUtilsMessageSeverityFlagBitsEXT severity, VkDebugUtilsMessageTypeFlagsEXT,
    const VkDebugUtilsMessengerCallbackDataEXT* data, void* user) {
  auto* ctx = static_cast<Context*>(user);
  const char* level = (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT) ? "error" : "warning";
  std::string msg = std::string("[vulkan ") + level + "] " + (data->pMessage ? data->pMessage : "");
  std::fprintf(stderr, "cressim: %s\n", msg.c_str());
  std::lock_guard<std::mutex> lock(ctx->messages_mutex);
  ctx->validation_messages.push_back(std::move(msg));
  return VK_FALSE;
}

bool has_layer(const char* name) {
  uint32_t n = 0;
  vkEnumerateInstanceLayerProperties(&n, nullptr);
  std::vector<VkLayerProperties> layers(n);
  vkEnumerateInstanceLayerProperties(&n, layers.data());
  return std::any_of(layers.begin(), layers.end(),
                     [&](const VkLayerProperties& l) { return std::strcmp(l.layerName, name) == 0; });
}

bool has_device_extension(VkPhysicalDevice pd, const char* name) {
  uint32_t n = 0;
  vkEnumerateDeviceExtensionProperties(pd, nullptr, &n, nullptr);
  std::vector<VkExtensionProperties> exts(n);
  vkEnumerateDeviceExtensionProperties(pd, nullptr, &n, exts.data());
  return std::any_of(exts.begin(), exts.end(),
                     [&](const VkExtensionProperties& e) { return std::strcmp(e.extensionName, name) == 0; });
}

VkInstance create_instance(bool validation) {
  VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
  app.pApplicationName = "cressim";
  app.pEngineName = "cressim";
  app.apiVersion = VK_API_VERSION_1_3;
  std::vector<const char*> layers, extensions;
  if (validation) {
    if (!has_layer(kValidationLayer))
      throw VulkanError(VK_ERROR_LAYER_NOT_PRESENT,
                        "CRESSIM_VALIDATION=1 but VK_LAYER_KHRONOS_validation is not installed "
                        "(Debian package vulkan-validationlayers)");
    layers.push_back(kValidationLayer);
    extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
  }
  VkInstanceCreateInfo ci{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  ci.pApplicationInfo = &app;
  ci.enabledLayerCount = uint32_t(layers.size());
  ci.ppEnabledLayerNames = layers.data();
  ci.enabledExtensionCount = uint32_t(extensions.size());
  ci.ppEnabledExtensionNames = extensions.data();
  VkInstance instance = VK_NULL_HANDLE;
  check(vkCreateInstance(&ci, nullptr, &instance), "vkCreateInstance");
  return instance;
}

// One VkInstance per process and validation setting, kept for the life of the process: the
// NVIDIA driver (580, H100) fails vkCreateInstance with VK_ERROR_INCOMPATIBLE_DRIVER after 30
// create/destroy cycles in one process, whatever is destroyed in between. Engines differ in
// their devices, which are theirs alone.
VkInstance shared_instance(bool validation) {
  static std::mutex mutex;
  static VkInstance instances[2] = {VK_NULL_HANDLE, VK_NULL_HANDLE};
  std::lock_guard<std::mutex> lock(mutex);
  VkInstance& instance = instances[validation ? 1 : 0];
  if (!instance) instance = create_instance(validation);
  return instance;
}

std::vector<VkPhysicalDevice> physical_devices(VkInstance instance) {
  uint32_t n = 0;
  check(vkEnumeratePhysicalDevices(instance, &n, nullptr), "vkEnumeratePhysicalDevices");
  std::vector<VkPhysicalDevice> devices(n);
  check(vkEnumeratePhysicalDevices(instance, &n, devices.data()), "vkEnumeratePhysicalDevices");
  return devices;
}

DeviceInfo describe(VkPhysicalDevice pd, uint32_t index) {
  VkPhysicalDeviceIDProperties ids{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ID_PROPERTIES};
  VkPhysicalDeviceDriverProperties driver{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES};
  driver.pNext = &ids;
  VkPhysicalDeviceProperties2 p2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
  p2.pNext = &driver;
  vkGetPhysicalDeviceProperties2(pd, &p2);
  DeviceInfo info;
  info.index = index;
  info.name = p2.properties.deviceName;
  info.type = type_name(p2.properties.deviceType);
  info.api_version = p2.properties.apiVersion;
  info.driver = std::string(driver.driverName) + " " + driver.driverInfo;
  static const char* hex = "0123456789abcdef";
  for (uint8_t b : ids.deviceUUID) info.uuid += {hex[b >> 4], hex[b & 15]};
  return info;
}

// CRESSIM_DEVICE / options.device: an index, or a case-insensitive substring of the name.
uint32_t choose_device(const std::vector<VkPhysicalDevice>& devices, const std::string& wanted) {
  if (devices.empty())
    throw VulkanError(VK_ERROR_INITIALIZATION_FAILED,
                      "no Vulkan device found; install mesa-vulkan-drivers (lavapipe) or a GPU driver");
  if (!wanted.empty()) {
    if (std::all_of(wanted.begin(), wanted.end(), ::isdigit)) {
      uint32_t i = uint32_t(std::stoul(wanted));
      if (i < devices.size()) return i;
    } else {
      auto lower = [](std::string s) { std::transform(s.begin(), s.end(), s.begin(), ::tolower); return s; };
      for (uint32_t i = 0; i < devices.size(); ++i)
        if (lower(describe(devices[i], i).name).find(lower(wanted)) != std::string::npos) return i;
    }
    std::string names;
    for (uint32_t i = 0; i < devices.size(); ++i) names += "\n  " + std::to_string(i) + ": " + describe(devices[i], i).name;
    throw VulkanError(VK_ERROR_INITIALIZATION_FAILED,
                      "CRESSIM_DEVICE='" + wanted + "' matches no device; devices are:" + names);
  }
  uint32_t best = 0;
  int best_rank = 1 << 30;
  for (uint32_t i = 0; i < devices.size(); ++i) {
    VkPhysicalDeviceProperties p;
    vkGetPhysicalDeviceProperties(devices[i], &p);
    if (p.apiVersion < VK_API_VERSION_1_3) continue;
    int rank = type_rank(p.deviceType);
    if (rank < best_rank) best = i, best_rank = rank;
  }
  if (best_rank == (1 << 30))
    throw VulkanError(VK_ERROR_INCOMPATIBLE_DRIVER, "no device supports Vulkan 1.3");
  return best;
}

std::atomic<bool> g_logged{false};

}  // namespace

Context::~Context() {
  if (device) {
    vkDeviceWaitIdle(device);
    if (command_pool) vkDestroyCommandPool(device, command_pool, nullptr);
    vkDestroyDevice(device, nullptr);
  }
  if (messenger) {
    auto destroy = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(instance, "vkDestroyDebugUtilsMessengerEXT"));
    if (destroy) destroy(instance, messenger, nullptr);
  }
  // the instance is shared (shared_instance) and outlives every context
}

// an on/off environment switch: on when set to anything but "" or "0"
static bool switched_on(const char* name) {
  const char* v = std::getenv(name);
  return v && std::strcmp(v, "") != 0 && std::strcmp(v, "0") != 0;
}

ContextOptions options_from_environment() {
  ContextOptions o;
  o.validation = switched_on("CRESSIM_VALIDATION");
  const char* d = std::getenv("CRESSIM_DEVICE");
  if (d) o.device = d;
  o.pipeline_statistics = switched_on("CRESSIM_PIPELINE_STATISTICS");
  return o;
}

std::vector<DeviceInfo> list_devices() {
  std::vector<DeviceInfo> out;
  auto devices = physical_devices(shared_instance(false));
  for (uint32_t i = 0; i < devices.size(); ++i) out.push_back(describe(devices[i], i));
  return out;
}

std::shared_ptr<Context> create_context(const ContextOptions& options) {
  auto ctx = std::make_shared<Context>();
  ctx->validation = options.validation;
  ctx->instance = shared_instance(options.validation);

  if (options.validation) {
    VkDebugUtilsMessengerCreateInfoEXT mi{VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT};
    mi.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
    mi.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                     VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
    mi.pfnUserCallback = on_validation_message;
    mi.pUserData = ctx.get();
    auto create = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(ctx->instance, "vkCreateDebugUtilsMessengerEXT"));
    check(create(ctx->instance, &mi, nullptr, &ctx->messenger), "vkCreateDebugUtilsMessengerEXT");
  }

  auto devices = physical_devices(ctx->instance);
  std::string wanted = options.device;
  uint32_t index = choose_device(devices, wanted);
  ctx->physical = devices[index];
  ctx->info = describe(ctx->physical, index);

  VkPhysicalDeviceIDProperties ids{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ID_PROPERTIES};
  VkPhysicalDeviceSubgroupProperties subgroup{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES};
  subgroup.pNext = &ids;
  VkPhysicalDeviceProperties2 p2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
  p2.pNext = &subgroup;
  vkGetPhysicalDeviceProperties2(ctx->physical, &p2);
  ctx->properties = p2.properties;
  ctx->subgroup_size = subgroup.subgroupSize;
  std::memcpy(ctx->device_uuid, ids.deviceUUID, VK_UUID_SIZE);
  vkGetPhysicalDeviceMemoryProperties(ctx->physical, &ctx->memory);
  ctx->unified_memory = ctx->properties.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU ||
                        ctx->properties.deviceType == VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU;

  // one queue family with compute (graphics arrives with the renderer and prefers a combined one)
  uint32_t nq = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(ctx->physical, &nq, nullptr);
  std::vector<VkQueueFamilyProperties> families(nq);
  vkGetPhysicalDeviceQueueFamilyProperties(ctx->physical, &nq, families.data());
  int family = -1;
  for (uint32_t i = 0; i < nq && family < 0; ++i)
    if ((families[i].queueFlags & (VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT)) ==
        (VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT)) family = int(i);
  for (uint32_t i = 0; i < nq && family < 0; ++i)
    if (families[i].queueFlags & VK_QUEUE_COMPUTE_BIT) family = int(i);
  if (family < 0) throw VulkanError(VK_ERROR_FEATURE_NOT_PRESENT, ctx->info.name + " has no compute queue");
  ctx->queue_family = uint32_t(family);

  std::vector<const char*> extensions;
  ctx->external_memory_fd = has_device_extension(ctx->physical, VK_KHR_EXTERNAL_MEMORY_FD_EXTENSION_NAME);
  ctx->external_semaphore_fd = has_device_extension(ctx->physical, VK_KHR_EXTERNAL_SEMAPHORE_FD_EXTENSION_NAME);
  if (ctx->external_memory_fd) extensions.push_back(VK_KHR_EXTERNAL_MEMORY_FD_EXTENSION_NAME);
  if (ctx->external_semaphore_fd) extensions.push_back(VK_KHR_EXTERNAL_SEMAPHORE_FD_EXTENSION_NAME);
  VkPhysicalDevicePipelineExecutablePropertiesFeaturesKHR executable_info{
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PIPELINE_EXECUTABLE_PROPERTIES_FEATURES_KHR};
  ctx->pipeline_statistics = options.pipeline_statistics &&
                             has_device_extension(ctx->physical, VK_KHR_PIPELINE_EXECUTABLE_PROPERTIES_EXTENSION_NAME);
  if (options.pipeline_statistics && !ctx->pipeline_statistics)
    std::fprintf(stderr, "cressim: %s reports no pipeline statistics (VK_KHR_pipeline_executable_properties)\n",
                 ctx->info.name.c_str());
  if (ctx->pipeline_statistics) {
    extensions.push_back(VK_KHR_PIPELINE_EXECUTABLE_PROPERTIES_EXTENSION_NAME);
    executable_info.pipelineExecutableInfo = VK_TRUE;
  }
  // cameras of many envs render in one pass, each instance writing its layer from the vertex
  // shader (SPIR-V 1.3 needs the extension; Vulkan 1.2 then wants both features on)
  bool output_layer = false;

  // features the engine relies on: timeline semaphores, sync2, buffer addresses, scalar layouts
  VkPhysicalDeviceVulkan13Features f13{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES};
  VkPhysicalDeviceVulkan12Features f12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
  VkPhysicalDeviceFeatures2 f2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
  f2.pNext = &f12;
  f12.pNext = &f13;
  vkGetPhysicalDeviceFeatures2(ctx->physical, &f2);
  if (!f12.timelineSemaphore || !f13.synchronization2)
    throw VulkanError(VK_ERROR_FEATURE_NOT_PRESENT, ctx->info.name + " lacks timeline semaphores or synchronization2");
  VkPhysicalDeviceVulkan13Features e13{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES};
  VkPhysicalDeviceVulkan12Features e12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
  VkPhysicalDeviceFeatures2 e2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
  e2.pNext = &e12;
  e12.pNext = &e13;
  if (ctx->pipeline_statistics) e13.pNext = &executable_info;
  e12.timelineSemaphore = VK_TRUE;
  e12.scalarBlockLayout = f12.scalarBlockLayout;
  e12.hostQueryReset = f12.hostQueryReset;
  e13.synchronization2 = VK_TRUE;
  e13.dynamicRendering = f13.dynamicRendering;
  output_layer = f12.shaderOutputLayer && f12.shaderOutputViewportIndex &&
                 has_device_extension(ctx->physical, VK_EXT_SHADER_VIEWPORT_INDEX_LAYER_EXTENSION_NAME);
  if (output_layer) extensions.push_back(VK_EXT_SHADER_VIEWPORT_INDEX_LAYER_EXTENSION_NAME);
  e12.shaderOutputLayer = output_layer;
  e12.shaderOutputViewportIndex = output_layer;
  e2.features.shaderFloat64 = f2.features.shaderFloat64;
  e2.features.shaderInt64 = f2.features.shaderInt64;
  // the rasterizer's culled draw lists (render/culling.h) where the device has them
  e2.features.drawIndirectFirstInstance = f2.features.drawIndirectFirstInstance;
  e2.features.multiDrawIndirect = f2.features.multiDrawIndirect;

  float priority = 1.0f;
  VkDeviceQueueCreateInfo qi{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
  qi.queueFamilyIndex = ctx->queue_family;
  qi.queueCount = 1;
  qi.pQueuePriorities = &priority;
  VkDeviceCreateInfo di{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
  di.pNext = &e2;
  di.queueCreateInfoCount = 1;
  di.pQueueCreateInfos = &qi;
  di.enabledExtensionCount = uint32_t(extensions.size());
  di.ppEnabledExtensionNames = extensions.data();
  check(vkCreateDevice(ctx->physical, &di, nullptr, &ctx->device), "vkCreateDevice");
  vkGetDeviceQueue(ctx->device, ctx->queue_family, 0, &ctx->queue);

  VkCommandPoolCreateInfo pi{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  pi.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  pi.queueFamilyIndex = ctx->queue_family;
  check(vkCreateCommandPool(ctx->device, &pi, nullptr, &ctx->command_pool), "vkCreateCommandPool");

  if (!g_logged.exchange(true))
    std::fprintf(stderr, "cressim: device %u: %s (%s, Vulkan %u.%u, %s)%s\n", index, ctx->info.name.c_str(),
                 ctx->info.type.c_str(), VK_API_VERSION_MAJOR(ctx->info.api_version),
                 VK_API_VERSION_MINOR(ctx->info.api_version), ctx->info.driver.c_str(),
                 ctx->validation ? " [validation on]" : "");
  return ctx;
}

}  // namespace cressim::gpu
