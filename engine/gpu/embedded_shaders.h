// Shaders compiled from shaders/ at build time by glslc, and the shared headers, in the library.
#pragma once
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace cressim::gpu {

// `name` is the path under shaders/ without ".comp.hlsl", e.g. "scene/reset_envs".
const std::vector<uint32_t>& embedded_shader(const std::string& name);
std::vector<std::string> embedded_shader_names();

// Shared headers by include name ("cressim/layout.h"), for user passes compiled at run time.
const std::map<std::string, std::string>& embedded_headers();

}  // namespace cressim::gpu
