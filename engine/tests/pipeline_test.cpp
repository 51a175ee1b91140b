#include "gpu/pipeline.h"

#include <gtest/gtest.h>

#include "gpu/error.h"
#include "gpu/shader_compiler.h"
#include "test_support.h"

using namespace cressim;

// a kernel whose group memory exceeds the device's is refused by name before Vulkan sees it
// (the validation layer would flag it; a driver may crash)
TEST(ComputePipeline, GroupMemoryBeyondTheDeviceIsRefusedByName) {
  auto ctx = test_support::validated_context();
  const uint32_t limit = ctx->properties.limits.maxComputeSharedMemorySize;
  const std::string src = "groupshared float4 big[" + std::to_string(limit / 16 + 1) + "];\n"
                          "RWStructuredBuffer<float> o;\n"
                          "[numthreads(64, 1, 1)] void main(uint3 t : SV_GroupThreadID) {\n"
                          "  big[t.x] = float4(t.x, 0, 0, 0);\n"
                          "  GroupMemoryBarrierWithGroupSync();\n"
                          "  o[t.x] = big[t.x ^ 1].x;\n"
                          "}\n";
  try {
    gpu::create_compute_pipeline(*ctx, gpu::compile_hlsl(src, "too_big", "main"), "main", "too_big");
    FAIL() << "expected a refusal";
  } catch (const gpu::VulkanError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("too_big"), std::string::npos) << what;
    EXPECT_NE(what.find(std::to_string(limit)), std::string::npos) << what;
  }
  test_support::expect_no_validation_messages(*ctx);
}
