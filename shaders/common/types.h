// Lets one header declare structs for both C++ and HLSL: HLSL's names mapped to C++ types.
#ifndef CRESSIM_TYPES_H
#define CRESSIM_TYPES_H
#ifdef __cplusplus
#include <cstdint>
namespace cressim::shader {
using uint = uint32_t;
struct float4 { float x, y, z, w; };
struct uint4 { uint32_t x, y, z, w; };
}  // namespace cressim::shader
#define CRESSIM_SHADER_BEGIN namespace cressim::shader {
#define CRESSIM_SHADER_END }
#else
#define CRESSIM_SHADER_BEGIN
#define CRESSIM_SHADER_END
#endif
#endif
