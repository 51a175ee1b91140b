#include "compute/compute_pass.h"

#include <algorithm>
#include <atomic>
#include <cstring>
#include <regex>

#include "compute/dispatch_stamps.h"
#include "compute/element_type.h"
#include "gpu/context.h"
#include "gpu/embedded_shaders.h"
#include "gpu/shader_compiler.h"

namespace cressim::compute {
namespace {

std::string list(std::vector<std::string> names) {
  std::sort(names.begin(), names.end());
  std::string s;
  for (auto& n : names) s += (s.empty() ? "" : ", ") + n;
  return s.empty() ? "(none)" : s;
}

std::shared_ptr<ComputePass> build(std::shared_ptr<gpu::Context> ctx, const std::string& name,
                                   const std::vector<uint32_t>& spirv, const std::string& entry,
                                   const std::map<std::string, std::shared_ptr<TypedBuffer>>& bindings,
                                   bool allow_internal_writes, const std::string* source,
                                   const std::set<std::string>& internal_writes = {}) {
  auto pass = std::make_shared<ComputePass>();
  static std::atomic<uint64_t> next_uid{1};
  pass->name = name;
  pass->uid = next_uid++;
  pass->ctx = ctx;
  pass->pipeline = gpu::create_compute_pipeline(*ctx, spirv, entry, name);
  const auto& refl = pass->pipeline.reflection;

  std::vector<std::string> declared, missing;
  for (const auto& b : refl.bindings) declared.push_back(b.name);
  // a buffer the shader declares but never uses is compiled away: that is fine, a name that is
  // nowhere in the source is a mistake
  for (const auto& [hlsl_name, buffer] : bindings)
    if (!refl.find_binding(hlsl_name) && source && !std::regex_search(*source, std::regex("\\b" + hlsl_name + "\\b")))
      throw BindingError("pass '" + name + "': bindings name '" + hlsl_name +
                         "', which the shader does not declare; its buffers are: " + list(declared));
  for (const auto& b : refl.bindings) {
    auto it = bindings.find(b.name);
    if (it == bindings.end() || !it->second) { missing.push_back(b.name); continue; }
    const TypedBuffer& buf = *it->second;
    if (b.writable && buf.read_only && !allow_internal_writes && !internal_writes.count(buf.key))
      throw BindingError("pass '" + name + "': '" + b.name + "' is bound to internal buffer " + buf.describe() +
                         ", which custom passes may only read; declare it StructuredBuffer<...>, not RW "
                         "(or name its key in internal_writes)");
    check_element_type(name, b, buf);
    gpu::bind_buffer(*ctx, pass->pipeline, b.binding, buf.storage->buffer.buffer);
    pass->bindings[b.name] = it->second;
  }
  if (!missing.empty())
    throw BindingError("pass '" + name + "': no buffer bound to shader buffer(s) " + list(missing) +
                       "; pass bindings={name: shared buffer or internal key}");
  pass->constants.assign(refl.push_constant_size, 0);
  return pass;
}

}  // namespace

ComputePass::~ComputePass() {
  if (ctx) gpu::destroy_compute_pipeline(*ctx, pipeline);
}

void ComputePass::set_constant_bits(const std::string& cname, const void* data, size_t size) {
  const auto* c = pipeline.reflection.find_constant(cname);
  if (!c) {
    std::vector<std::string> names;
    for (auto& k : pipeline.reflection.constants) names.push_back(k.name);
    throw BindingError("pass '" + name + "': no push constant '" + cname + "'; its constants are: " + list(names));
  }
  if (size != c->size)
    throw BindingError("pass '" + name + "': constant '" + cname + "' has " + std::to_string(c->size) +
                       " bytes, got " + std::to_string(size));
  std::memcpy(constants.data() + c->offset, data, size);
  ++version;
}

void ComputePass::set_constant(const std::string& cname, double value) {
  const auto* c = pipeline.reflection.find_constant(cname);
  if (!c) return set_constant_bits(cname, nullptr, 0);  // throws, listing the pass's constants
  if (c->components != 1)
    throw BindingError("pass '" + name + "': constant '" + cname + "' has " + std::to_string(c->components) +
                       " components; give a sequence of that length");
  if (c->kind == gpu::ScalarKind::FLOAT && c->size == 4) { float v = float(value); set_constant_bits(cname, &v, 4); }
  else if (c->kind == gpu::ScalarKind::FLOAT) { set_constant_bits(cname, &value, 8); }
  else if (c->kind == gpu::ScalarKind::INT) { int32_t v = int32_t(value); set_constant_bits(cname, &v, 4); }
  else {
    if (value < 0) throw BindingError("pass '" + name + "': constant '" + cname + "' is unsigned, got a negative value");
    uint32_t v = uint32_t(value);
    set_constant_bits(cname, &v, 4);
  }
}

void ComputePass::set_threads(std::array<uint64_t, 3> threads) {
  const auto& ls = pipeline.reflection.local_size;
  for (int i = 0; i < 3; ++i) groups[i] = uint32_t((std::max<uint64_t>(threads[i], 1) + ls[i] - 1) / ls[i]);
  const uint32_t* limit = ctx->properties.limits.maxComputeWorkGroupCount;
  for (int i = 0; i < 3; ++i)
    if (groups[i] > limit[i])
      throw BindingError("pass '" + name + "': " + std::to_string(groups[i]) + " groups in dimension " +
                         std::to_string(i) + " exceed the device limit " + std::to_string(limit[i]));
  ++version;
}

void ComputePass::record(VkCommandBuffer cmd) const {
  gpu::record_dispatch(cmd, pipeline, constants.data(), groups.data());
  if (auto* stamps = active_dispatch_stamps(); stamps && stamps->passes) stamps->stamp(cmd, name);
}

std::shared_ptr<ComputePass> create_compute_pass(std::shared_ptr<gpu::Context> ctx, const PassSpec& spec) {
  auto spirv = gpu::compile_hlsl(spec.source, spec.name, spec.entry);
  auto pass = build(ctx, spec.name, spirv, spec.entry, spec.bindings, false, &spec.source, spec.internal_writes);
  if (spec.threads[0]) pass->set_threads(spec.threads);
  else if (spec.groups[0]) pass->set_groups(spec.groups);
  else throw BindingError("pass '" + spec.name + "': give dispatch=(groups x, y, z) or threads=n");
  return pass;
}

std::shared_ptr<ComputePass> create_builtin_pass(std::shared_ptr<gpu::Context> ctx, const std::string& shader,
                                                 std::map<std::string, std::shared_ptr<TypedBuffer>> bindings,
                                                 bool allow_internal_writes) {
  return build(ctx, shader, gpu::embedded_shader(shader), "main", bindings, allow_internal_writes, nullptr);
}

}  // namespace cressim::compute
