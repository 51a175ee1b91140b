#include "render/mip_chain.h"

#include <gtest/gtest.h>

#include <vector>

using namespace cressim;

namespace {
uint32_t grey(uint32_t v) { return v | (v << 8) | (v << 16) | (0xffu << 24); }
}  // namespace

TEST(MipChain, CheckerAveragesInLinearLight) {
  // 4x4 one-texel checker: levels 2x2 and 1x1, each half white in linear light -> 0.5 -> 186
  std::vector<uint32_t> texels{7};  // an earlier texture's texel stays as it was
  for (uint32_t y = 0; y < 4; ++y)
    for (uint32_t x = 0; x < 4; ++x) texels.push_back(grey((x + y) % 2 ? 255 : 0));
  EXPECT_EQ(render::append_mip_chain(texels, 4, 4), 3u);
  ASSERT_EQ(texels.size(), 1u + 16 + 4 + 1);
  EXPECT_EQ(texels[0], 7u);
  for (size_t i = 17; i < texels.size(); ++i) EXPECT_EQ(texels[i], grey(186)) << i;
}

TEST(MipChain, OddSizesFoldTheirLastRowAndColumn) {
  // 5x3: level 1 is 2x1 (columns 0-1 and 2-4, all three rows), level 2 is 1x1
  std::vector<uint32_t> texels;
  for (uint32_t y = 0; y < 3; ++y)
    for (uint32_t x = 0; x < 5; ++x) texels.push_back(grey(x < 2 ? 255 : 0));
  EXPECT_EQ(render::append_mip_chain(texels, 5, 3), 3u);
  ASSERT_EQ(texels.size(), 15u + 2 + 1);
  EXPECT_EQ(texels[15], grey(255));
  EXPECT_EQ(texels[16], grey(0));
  EXPECT_EQ(texels[17], grey(186));  // (1 + 0) / 2 in linear light
}
