// Sizes of the image-based lighting buffers (engine/render/environment_map.*,
// shaders/render/ibl_*.comp.hlsl). Every distinct environment map (texture, intensity) has a
// slot: its radiance box-filtered to an equirectangular grid, the SH9 of its irradiance, and
// specular prefiltered maps at a few GGX roughness levels.
#ifndef CRESSIM_IBL_H
#define CRESSIM_IBL_H
#include "cressim/types.h"

CRESSIM_SHADER_BEGIN

static const uint IBL_GRID_W = 128, IBL_GRID_H = 64;  // render.ibl_grid (slots, H, W) float4 radiance
static const uint IBL_SH = 9;                         // render.ibl_sh (slots, 9) float4
static const uint IBL_LEVELS = 4;                     // roughness (k + 1) / IBL_LEVELS; 0: the map itself
static const uint IBL_SPEC_W = 32, IBL_SPEC_H = 16;   // render.ibl_specular (slots, levels, H, W) float4

CRESSIM_SHADER_END
#endif
