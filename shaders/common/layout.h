// Struct layouts and constants shared by the C++ engine and its HLSL shaders.
// User passes may #include "cressim/layout.h" too.
#ifndef CRESSIM_LAYOUT_H
#define CRESSIM_LAYOUT_H
#include "cressim/types.h"

CRESSIM_SHADER_BEGIN

// Thread-group width of the engine's 1-D passes (a multiple of every subgroup size we meet).
static const uint CRESSIM_GROUP_SIZE = 64;

// scene/reset_envs: rows whose env is flagged in env.reset_mask go back to their initial state,
// and the env's reset counter (env.reset_count) goes up by one.
struct ResetEnvsConstants {
  uint row_count;
  uint env_count;
};

CRESSIM_SHADER_END
#endif
