// Pass-level profiling: while a frame is recorded with these stamps active, every compute pass
// writes a GPU timestamp after its dispatch, so a profile names the pass inside a stage (physics,
// sensors, a task's passes) that takes the time, not only the stage.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <vulkan/vulkan.h>

namespace cressim::compute {

struct DispatchStamps {
  VkQueryPool pool = VK_NULL_HANDLE;
  uint32_t capacity = 0;
  bool passes = false;               // stamp each compute pass, not only what the caller stamps
  std::vector<std::string> labels;   // labels[i]: what ran between stamp i - 1 and stamp i
  std::vector<int> ops;              // ops[i]: the frame op stamp i belongs to (-1: the start)
  int op = -1;                       // the op being recorded
  bool overflowed = false;

  void stamp(VkCommandBuffer cmd, const std::string& label);
};

// The stamps of the frame being recorded on this thread (null: not profiling passes).
DispatchStamps*& active_dispatch_stamps();

}  // namespace cressim::compute
