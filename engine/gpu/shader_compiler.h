// HLSL -> SPIR-V at run time with libshaderc, same options as the build-time glslc step.
#pragma once
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace cressim::gpu {

// The compiler's own message, with "name:line: error: ..." lines.
struct ShaderCompileError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// `name` is used in messages and to resolve relative #includes (its directory, if a path);
// `#include "cressim/..."` resolves to the engine's shared headers embedded in the library.
std::vector<uint32_t> compile_hlsl(const std::string& source, const std::string& name, const std::string& entry);

}  // namespace cressim::gpu
