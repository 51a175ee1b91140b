// Image-based lighting (EnvironmentLight.map): every distinct (map, intensity) is a slot,
// filtered on the GPU once when the renderer is built (the maps are world textures, fixed
// after upload_world): the map box-filtered to a 128 x 64 radiance grid
// (ibl_grid.comp.hlsl), the grid's irradiance as SH9 (ibl_sh.comp.hlsl) and GGX-prefiltered
// 32 x 16 maps at roughness 0.25, 0.5, 0.75, 1 (ibl_specular.comp.hlsl). Shading reads
// "render.ibl_sh" and "render.ibl_specular" (image_lighting.hlsli).
#pragma once
#include <memory>

#include "compute/typed_buffer.h"
#include "render/render_model.h"

namespace cressim::render {

// Makes render.ibl_sh and render.ibl_specular (one stand-in slot when no env has a map) and
// fills them. bound: the renderer's texture_infos and texels.
void build_environment_maps(std::shared_ptr<gpu::Context> ctx, const RenderModel& model, uint64_t generation,
                            compute::BufferMap& internal, compute::BufferMap& bound);

}  // namespace cressim::render
