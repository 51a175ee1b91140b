#include "gpu/buffer.h"

#include <numeric>
#include <vector>

#include "test_support.h"

using namespace cressim;

TEST(Buffer, RoundTripThroughEveryMemoryKind) {
  auto ctx = test_support::validated_context();
  for (gpu::Memory kind : {gpu::Memory::DEVICE, gpu::Memory::UPLOAD, gpu::Memory::READBACK}) {
    std::vector<float> in(1 << 16), out(in.size());
    std::iota(in.begin(), in.end(), 0.5f);
    gpu::Buffer b = gpu::create_buffer(*ctx, in.size() * 4, {kind});
    gpu::upload(*ctx, b, in.data(), in.size() * 4);
    gpu::readback(*ctx, b, out.data(), out.size() * 4);
    EXPECT_EQ(in, out);
    gpu::destroy_buffer(*ctx, b);
  }
  test_support::expect_no_validation_messages(*ctx);
}

TEST(Buffer, FillAndPartialCopies) {
  auto ctx = test_support::validated_context();
  gpu::Buffer b = gpu::create_buffer(*ctx, 64, {});
  gpu::fill(*ctx, b, 0x01010101u);
  uint32_t v = 7;
  gpu::upload(*ctx, b, &v, 4, 8);
  uint32_t out[4];
  gpu::readback(*ctx, b, out, 16);
  EXPECT_EQ(out[0], 0x01010101u);
  EXPECT_EQ(out[2], 7u);
  EXPECT_THROW(gpu::upload(*ctx, b, &v, 4, 64), std::out_of_range);
  gpu::destroy_buffer(*ctx, b);
  test_support::expect_no_validation_messages(*ctx);
}
