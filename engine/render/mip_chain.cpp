#include "render/mip_chain.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace cressim::render {
namespace {

std::array<float, 256> decode_table() {
  std::array<float, 256> t{};
  for (int i = 0; i < 256; ++i) t[i] = std::pow(i / 255.f, 2.2f);
  return t;
}

}  // namespace

uint32_t append_mip_chain(std::vector<uint32_t>& texels, uint32_t width, uint32_t height, bool srgb) {
  static const std::array<float, 256> decoded = decode_table();
  auto linear = [&](uint32_t byte) { return srgb ? decoded[byte] : byte / 255.f; };
  uint32_t levels = 1;
  size_t above = texels.size() - size_t(width) * height;
  while (width > 1 || height > 1) {
    const uint32_t w = std::max(1u, width / 2), h = std::max(1u, height / 2);
    const size_t first = texels.size();
    texels.resize(first + size_t(w) * h);
    for (uint32_t y = 0; y < h; ++y)
      for (uint32_t x = 0; x < w; ++x) {
        // the source rows and columns this texel averages: 2 each, 3 at an odd edge
        const uint32_t x0 = std::min(2 * x, width - 1), x1 = (x + 1 == w) ? width : std::min(2 * x + 2, width);
        const uint32_t y0 = std::min(2 * y, height - 1), y1 = (y + 1 == h) ? height : std::min(2 * y + 2, height);
        float sum[4] = {0, 0, 0, 0};
        for (uint32_t sy = y0; sy < y1; ++sy)
          for (uint32_t sx = x0; sx < x1; ++sx) {
            const uint32_t v = texels[above + size_t(sy) * width + sx];
            for (int c = 0; c < 3; ++c) sum[c] += linear((v >> (8 * c)) & 0xff);
            sum[3] += (v >> 24) / 255.f;  // alpha is linear already
          }
        const float n = float((x1 - x0) * (y1 - y0));
        uint32_t out = 0;
        for (int c = 0; c < 4; ++c) {
          const float v = c < 3 && srgb ? std::pow(sum[c] / n, 1 / 2.2f) : sum[c] / n;
          out |= uint32_t(std::lround(std::clamp(v, 0.f, 1.f) * 255)) << (8 * c);
        }
        texels[first + size_t(y) * w + x] = out;
      }
    above = first;
    width = w, height = h;
    ++levels;
  }
  return levels;
}

}  // namespace cressim::render
