#include "gpu/context.h"

#include "gpu/error.h"
#include "test_support.h"

using namespace cressim;

TEST(Context, CreatesAValidatedVulkan13Device) {
  auto ctx = test_support::validated_context();
  EXPECT_TRUE(ctx->validation);
  EXPECT_NE(ctx->messenger, VK_NULL_HANDLE);
  EXPECT_GE(ctx->info.api_version, VK_API_VERSION_1_3);
  EXPECT_GT(ctx->subgroup_size, 0u);
  test_support::expect_no_validation_messages(*ctx);
}

TEST(Context, PrefersTheBestDeviceType) {
  auto devices = gpu::list_devices();
  ASSERT_FALSE(devices.empty());
  auto ctx = gpu::create_context({});
  const char* order[] = {"discrete", "integrated", "virtual", "cpu", "other"};
  auto rank = [&](const std::string& t) { return std::find(std::begin(order), std::end(order), t) - std::begin(order); };
  for (auto& d : devices) EXPECT_LE(rank(ctx->info.type), rank(d.type)) << d.name;
}

TEST(Context, OverrideByIndexAndUnknownName) {
  gpu::ContextOptions o;
  o.device = "0";
  EXPECT_EQ(gpu::create_context(o)->info.index, 0u);
  o.device = "surely-not-a-gpu";
  EXPECT_THROW(gpu::create_context(o), gpu::VulkanError);
}
