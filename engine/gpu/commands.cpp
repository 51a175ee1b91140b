#include "gpu/commands.h"

#include "gpu/context.h"
#include "gpu/error.h"

#include <chrono>

namespace cressim::gpu {

VkCommandBuffer allocate_command_buffer(Context& ctx) {
  VkCommandBufferAllocateInfo ai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  ai.commandPool = ctx.command_pool;
  ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  ai.commandBufferCount = 1;
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  check(vkAllocateCommandBuffers(ctx.device, &ai, &cmd), "vkAllocateCommandBuffers");
  return cmd;
}

void free_command_buffer(Context& ctx, VkCommandBuffer cmd) {
  if (cmd) vkFreeCommandBuffers(ctx.device, ctx.command_pool, 1, &cmd);
}

void begin_commands(VkCommandBuffer cmd, bool one_time) {
  VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  bi.flags = one_time ? VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT : 0;
  check(vkBeginCommandBuffer(cmd, &bi), "vkBeginCommandBuffer");
}

void end_commands(VkCommandBuffer cmd) { check(vkEndCommandBuffer(cmd), "vkEndCommandBuffer"); }

static void memory_barrier(VkCommandBuffer cmd, VkPipelineStageFlags2 dst_stage, VkAccessFlags2 dst_access) {
  VkMemoryBarrier2 mb{VK_STRUCTURE_TYPE_MEMORY_BARRIER_2};
  mb.srcStageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
  mb.srcAccessMask = VK_ACCESS_2_MEMORY_WRITE_BIT;
  mb.dstStageMask = dst_stage;
  mb.dstAccessMask = dst_access;
  VkDependencyInfo di{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
  di.memoryBarrierCount = 1;
  di.pMemoryBarriers = &mb;
  vkCmdPipelineBarrier2(cmd, &di);
}

void compute_barrier(VkCommandBuffer cmd) {
  // graphics stages too: the rasterizer reads what physics and passes wrote
  memory_barrier(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT);
}

void host_read_barrier(VkCommandBuffer cmd) {
  memory_barrier(cmd, VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
}

void submit_now(Context& ctx, const std::function<void(VkCommandBuffer)>& record) {
  VkCommandBuffer cmd = allocate_command_buffer(ctx);
  begin_commands(cmd, true);
  record(cmd);
  host_read_barrier(cmd);
  end_commands(cmd);
  VkFenceCreateInfo fi{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  VkFence fence = VK_NULL_HANDLE;
  check(vkCreateFence(ctx.device, &fi, nullptr, &fence), "vkCreateFence");
  VkCommandBufferSubmitInfo ci{VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO};
  ci.commandBuffer = cmd;
  VkSubmitInfo2 si{VK_STRUCTURE_TYPE_SUBMIT_INFO_2};
  si.commandBufferInfoCount = 1;
  si.pCommandBufferInfos = &ci;
  VkResult r = vkQueueSubmit2(ctx.queue, 1, &si, fence);
  if (r == VK_SUCCESS) r = vkWaitForFences(ctx.device, 1, &fence, VK_TRUE, UINT64_MAX);
  vkDestroyFence(ctx.device, fence, nullptr);
  free_command_buffer(ctx, cmd);
  check(r, "one-off transfer submit", "transfer");
}

Timeline create_timeline(Context& ctx, bool exportable) {
  VkExportSemaphoreCreateInfo ei{VK_STRUCTURE_TYPE_EXPORT_SEMAPHORE_CREATE_INFO};
  ei.handleTypes = VK_EXTERNAL_SEMAPHORE_HANDLE_TYPE_OPAQUE_FD_BIT;
  VkSemaphoreTypeCreateInfo ti{VK_STRUCTURE_TYPE_SEMAPHORE_TYPE_CREATE_INFO};
  ti.pNext = exportable && ctx.external_semaphore_fd ? &ei : nullptr;
  ti.semaphoreType = VK_SEMAPHORE_TYPE_TIMELINE;
  ti.initialValue = 0;
  VkSemaphoreCreateInfo si{VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO};
  si.pNext = &ti;
  Timeline t;
  check(vkCreateSemaphore(ctx.device, &si, nullptr, &t.semaphore), "vkCreateSemaphore(timeline)");
  return t;
}

int export_semaphore_fd(Context& ctx, const Timeline& t) {
  auto get_fd = reinterpret_cast<PFN_vkGetSemaphoreFdKHR>(vkGetDeviceProcAddr(ctx.device, "vkGetSemaphoreFdKHR"));
  if (!get_fd) throw VulkanError(VK_ERROR_EXTENSION_NOT_PRESENT, "VK_KHR_external_semaphore_fd is not available");
  VkSemaphoreGetFdInfoKHR info{VK_STRUCTURE_TYPE_SEMAPHORE_GET_FD_INFO_KHR};
  info.semaphore = t.semaphore;
  info.handleType = VK_EXTERNAL_SEMAPHORE_HANDLE_TYPE_OPAQUE_FD_BIT;
  int fd = -1;
  check(get_fd(ctx.device, &info, &fd), "vkGetSemaphoreFdKHR");
  return fd;
}

void destroy_timeline(Context& ctx, Timeline& t) {
  if (t.semaphore) vkDestroySemaphore(ctx.device, t.semaphore, nullptr);
  t = Timeline{};
}

uint64_t submit(Context& ctx, Timeline& t, const std::vector<VkCommandBuffer>& cmds, const std::string& stage,
                uint64_t wait_value) {
  std::vector<VkCommandBufferSubmitInfo> infos;
  infos.reserve(cmds.size());
  for (VkCommandBuffer c : cmds) {
    VkCommandBufferSubmitInfo ci{VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO};
    ci.commandBuffer = c;
    infos.push_back(ci);
  }
  // the value another API signals is one the timeline passes through
  if (wait_value > t.value) t.value = wait_value;
  VkSemaphoreSubmitInfo wait{VK_STRUCTURE_TYPE_SEMAPHORE_SUBMIT_INFO};
  wait.semaphore = t.semaphore;
  wait.value = wait_value;
  wait.stageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
  VkSemaphoreSubmitInfo signal{VK_STRUCTURE_TYPE_SEMAPHORE_SUBMIT_INFO};
  signal.semaphore = t.semaphore;
  signal.value = t.value + 1;
  signal.stageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
  VkSubmitInfo2 si{VK_STRUCTURE_TYPE_SUBMIT_INFO_2};
  si.waitSemaphoreInfoCount = wait_value ? 1 : 0;
  si.pWaitSemaphoreInfos = &wait;
  si.commandBufferInfoCount = uint32_t(infos.size());
  si.pCommandBufferInfos = infos.data();
  si.signalSemaphoreInfoCount = 1;
  si.pSignalSemaphoreInfos = &signal;
  check(vkQueueSubmit2(ctx.queue, 1, &si, VK_NULL_HANDLE), "vkQueueSubmit2", stage);
  return ++t.value;
}

// How long a host wait polls the timeline before it sleeps in the driver. Waking from the
// driver's sleep costs tens of microseconds, as much as a whole small frame's GPU time; polling
// a GPU's timeline is a memory read. Not on a CPU device (lavapipe): there the poll would take a
// core from the threads doing the frame's work.
constexpr auto kPollBeforeSleep = std::chrono::microseconds(1000);

void wait(Context& ctx, const Timeline& t, uint64_t value, const std::string& stage) {
  if (ctx.properties.deviceType != VK_PHYSICAL_DEVICE_TYPE_CPU) {
    const auto until = std::chrono::steady_clock::now() + kPollBeforeSleep;
    uint64_t reached = 0;
    do {
      check(vkGetSemaphoreCounterValue(ctx.device, t.semaphore, &reached), "vkGetSemaphoreCounterValue", stage);
      if (reached >= value) return;
    } while (std::chrono::steady_clock::now() < until);
  }
  VkSemaphoreWaitInfo wi{VK_STRUCTURE_TYPE_SEMAPHORE_WAIT_INFO};
  wi.semaphoreCount = 1;
  wi.pSemaphores = &t.semaphore;
  wi.pValues = &value;
  check(vkWaitSemaphores(ctx.device, &wi, UINT64_MAX), "vkWaitSemaphores", stage);
}

}  // namespace cressim::gpu
