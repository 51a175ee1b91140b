// What a compute shader declares, read from its SPIR-V: descriptor bindings (by HLSL name),
// push-constant members, the thread-group size and its group memory. Bindings are written once,
// in the shader.
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace cressim::gpu {

enum class ScalarKind { NONE = 0, UINT, INT, FLOAT };

struct ReflectedBinding {
  std::string name;
  uint32_t set = 0;
  uint32_t binding = 0;
  bool writable = true;  // false for StructuredBuffer/ByteAddressBuffer (NonWritable)
  uint32_t stride = 0;   // element stride of the runtime array, 0 if unknown
  // the element: a scalar or vector (kind, bits per component, components), or a struct (kind NONE)
  ScalarKind element_kind = ScalarKind::NONE;
  uint32_t element_bits = 0, element_components = 0;
  std::string element_type;  // as HLSL spells it: "float4", "uint", or the struct's name
};

struct ReflectedConstant {
  std::string name;
  uint32_t offset = 0;
  uint32_t size = 0;
  ScalarKind kind = ScalarKind::NONE;
  uint32_t components = 1;
};

struct ShaderReflection {
  std::vector<ReflectedBinding> bindings;
  std::vector<ReflectedConstant> constants;  // push-constant members
  uint32_t push_constant_size = 0;
  std::array<uint32_t, 3> local_size{1, 1, 1};
  uint32_t workgroup_bytes = 0;  // groupshared variables, at their natural sizes (as the validation layer counts)

  const ReflectedBinding* find_binding(const std::string& name) const;
  const ReflectedConstant* find_constant(const std::string& name) const;
};

ShaderReflection reflect_spirv(const std::vector<uint32_t>& code);

}  // namespace cressim::gpu
