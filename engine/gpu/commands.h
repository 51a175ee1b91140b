// Command recording helpers, barriers and timeline-semaphore submits.
#pragma once
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <vulkan/vulkan.h>

namespace cressim::gpu {

struct Context;

VkCommandBuffer allocate_command_buffer(Context& ctx);
void free_command_buffer(Context& ctx, VkCommandBuffer cmd);
void begin_commands(VkCommandBuffer cmd, bool one_time);
void end_commands(VkCommandBuffer cmd);

// Every shader/transfer write before is visible to every shader/transfer access after.
void compute_barrier(VkCommandBuffer cmd);
// Makes transfer and shader writes visible to host reads after the submit completes.
void host_read_barrier(VkCommandBuffer cmd);

// Records with `record`, submits and waits; for set-up and explicit copies, never per step.
void submit_now(Context& ctx, const std::function<void(VkCommandBuffer)>& record);

struct Timeline {
  VkSemaphore semaphore = VK_NULL_HANDLE;
  uint64_t value = 0;  // last value signalled by a submit
};

// exportable: an OPAQUE_FD-exportable semaphore (for CUDA), where the device can
Timeline create_timeline(Context& ctx, bool exportable = false);
int export_semaphore_fd(Context& ctx, const Timeline& t);
void destroy_timeline(Context& ctx, Timeline& t);

// One vkQueueSubmit2 of `cmds` that signals the next timeline value; returns that value.
// wait_value > 0: the GPU first waits for the timeline to reach it (signalled by CUDA).
uint64_t submit(Context& ctx, Timeline& t, const std::vector<VkCommandBuffer>& cmds, const std::string& stage,
                uint64_t wait_value = 0);
// Waits on the host until the timeline reaches `value`; device loss names `stage`.
void wait(Context& ctx, const Timeline& t, uint64_t value, const std::string& stage);

}  // namespace cressim::gpu
