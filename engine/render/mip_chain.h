// Mip levels of an RGBA8 texture: textures seen from afar cover many texels per pixel, and a
// single bilinear lookup then aliases into noise (at 64x64 most textured surfaces are).
#pragma once

#include <cstdint>
#include <vector>

namespace cressim::render {

// Appends the levels below the given one (width x height words, already at the end of texels)
// down to 1x1, each the 2x2 box average of the one above: in linear light for colours (srgb:
// gamma 2.2, as the shaders decode), of the stored values otherwise (normal maps); odd sizes
// round down and the last row/column folds into the average. Returns the number of levels, the
// given one included. Level k starts after levels 0..k-1.
uint32_t append_mip_chain(std::vector<uint32_t>& texels, uint32_t width, uint32_t height, bool srgb = true);

}  // namespace cressim::render
