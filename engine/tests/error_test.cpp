#include "gpu/error.h"

#include <gtest/gtest.h>

using namespace cressim::gpu;

TEST(Error, SuccessDoesNotThrow) { EXPECT_NO_THROW(check(VK_SUCCESS, "x")); }

TEST(Error, DeviceLossNamesTheLastStage) {
  try {
    check(VK_ERROR_DEVICE_LOST, "vkWaitSemaphores", "pass 'reward'");
    FAIL() << "no exception";
  } catch (const DeviceLostError& e) {
    EXPECT_EQ(e.stage, "pass 'reward'");
    EXPECT_NE(std::string(e.what()).find("last stage run: pass 'reward'"), std::string::npos);
  }
}

TEST(Error, OtherFailuresNameTheCallAndResult) {
  try {
    check(VK_ERROR_OUT_OF_DEVICE_MEMORY, "vkAllocateMemory");
    FAIL() << "no exception";
  } catch (const DeviceLostError&) {
    FAIL() << "not a device loss";
  } catch (const VulkanError& e) {
    EXPECT_EQ(e.result, VK_ERROR_OUT_OF_DEVICE_MEMORY);
    EXPECT_NE(std::string(e.what()).find("vkAllocateMemory failed: VK_ERROR_OUT_OF_DEVICE_MEMORY"), std::string::npos);
  }
}
