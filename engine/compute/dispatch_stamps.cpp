#include "compute/dispatch_stamps.h"

namespace cressim::compute {

void DispatchStamps::stamp(VkCommandBuffer cmd, const std::string& label) {
  if (labels.size() >= capacity) {
    overflowed = true;
    return;
  }
  vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, pool, uint32_t(labels.size()));
  labels.push_back(label);
  ops.push_back(op);
}

DispatchStamps*& active_dispatch_stamps() {
  thread_local DispatchStamps* active = nullptr;
  return active;
}

}  // namespace cressim::compute
