// The frame as a list of stage operations. A list seen before replays its recorded command
// buffer; a new list (or a changed pass) is recorded once and cached.
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <vulkan/vulkan.h>

namespace cressim::compute { struct ComputePass; }

namespace cressim::runtime {

enum class Stage { NONE = 0, UPLOAD, RESET, PHYSICS, VISUAL_SENSORS, SIMULATION_SENSORS, CUSTOM_PASS };

const char* stage_name(Stage s);

struct FrameOp {
  Stage stage = Stage::NONE;
  std::shared_ptr<compute::ComputePass> pass;  // CUSTOM_PASS only; kept alive while recorded
  uint64_t pass_uid = 0, pass_version = 0;
  bool operator==(const FrameOp& o) const {
    return stage == o.stage && pass_uid == o.pass_uid && pass_version == o.pass_version;
  }
  std::string label() const;
};

struct RecordedFrame {
  std::vector<FrameOp> ops;
  uint64_t epoch = 0;      // engine resource epoch it was recorded against
  bool profiled = false;   // brackets every op with timestamps
  bool passes = false;     // and stamps every compute pass inside them
  std::vector<std::string> stamp_labels;  // what each timestamp closes (compute/dispatch_stamps.h)
  std::vector<int> stamp_ops;             // the op each timestamp belongs to (-1: the frame's start)
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  uint64_t last_used = 0;
};

}  // namespace cressim::runtime
