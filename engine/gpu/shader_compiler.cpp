#include "gpu/shader_compiler.h"

#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>

#include <shaderc/shaderc.hpp>

#include "gpu/embedded_shaders.h"

namespace cressim::gpu {
namespace {

struct Included {
  std::string name, content;
};

class Includer : public shaderc::CompileOptions::IncluderInterface {
 public:
  explicit Includer(std::filesystem::path base) : base_(std::move(base)) {}

  shaderc_include_result* GetInclude(const char* requested, shaderc_include_type, const char* requesting,
                                     size_t) override {
    auto* inc = new Included;
    const std::string req = requested;
    const auto& headers = embedded_headers();
    if (auto it = headers.find(req); it != headers.end()) {
      inc->name = req;
      inc->content = it->second;
    } else {
      std::filesystem::path from = std::filesystem::path(requesting).parent_path();
      for (const auto& dir : {from, base_}) {
        std::ifstream f(dir / req);
        if (!f) continue;
        std::stringstream ss;
        ss << f.rdbuf();
        inc->name = (dir / req).string();
        inc->content = ss.str();
        break;
      }
    }
    auto* r = new shaderc_include_result{};
    if (inc->name.empty()) inc->content = "cannot find include file '" + req + "'";
    r->source_name = inc->name.c_str();
    r->source_name_length = inc->name.size();
    r->content = inc->content.c_str();
    r->content_length = inc->content.size();
    r->user_data = inc;
    return r;
  }

  void ReleaseInclude(shaderc_include_result* r) override {
    delete static_cast<Included*>(r->user_data);
    delete r;
  }

 private:
  std::filesystem::path base_;
};

}  // namespace

std::vector<uint32_t> compile_hlsl(const std::string& source, const std::string& name, const std::string& entry) {
  shaderc::Compiler compiler;
  shaderc::CompileOptions options;
  options.SetSourceLanguage(shaderc_source_language_hlsl);
  options.SetTargetEnvironment(shaderc_target_env_vulkan, shaderc_env_version_vulkan_1_3);
  // SPIR-V 1.3: the HLSL front end still emits BufferBlock, which 1.4+ forbids
  options.SetTargetSpirv(shaderc_spirv_version_1_3);
  options.SetAutoBindUniforms(true);
  options.SetOptimizationLevel(shaderc_optimization_level_performance);
  options.SetGenerateDebugInfo();  // keeps OpName: bindings are resolved by their HLSL names
  options.SetIncluder(std::make_unique<Includer>(std::filesystem::path(name).parent_path()));
  auto result = compiler.CompileGlslToSpv(source, shaderc_compute_shader, name.c_str(), entry.c_str(), options);
  if (result.GetCompilationStatus() != shaderc_compilation_status_success)
    throw ShaderCompileError("HLSL compile of '" + name + "' (entry '" + entry + "') failed:\n" +
                             result.GetErrorMessage());
  return {result.cbegin(), result.cend()};
}

}  // namespace cressim::gpu
