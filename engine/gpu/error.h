// Errors raised by the gpu layer; the Python binding maps each to its own exception type.
#pragma once
#include <stdexcept>
#include <string>

#include <vulkan/vulkan.h>

namespace cressim::gpu {

struct VulkanError : std::runtime_error {
  VkResult result;
  VulkanError(VkResult r, const std::string& what) : std::runtime_error(what), result(r) {}
};

// The device is gone; `stage` names the last frame stage that was submitted.
struct DeviceLostError : VulkanError {
  std::string stage;
  DeviceLostError(const std::string& stage_name, const std::string& what)
      : VulkanError(VK_ERROR_DEVICE_LOST, what), stage(stage_name) {}
};

const char* result_name(VkResult r);

// Throws VulkanError (DeviceLostError for VK_ERROR_DEVICE_LOST) naming `what` and `stage`.
void check(VkResult r, const char* what, const std::string& stage = "");

}  // namespace cressim::gpu
