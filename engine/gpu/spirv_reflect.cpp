#include "gpu/spirv_reflect.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <unordered_map>

#include <spirv/unified1/spirv.h>

namespace cressim::gpu {
namespace {

struct Id {
  uint32_t opcode = 0;
  std::string name;
  uint32_t storage_class = 0;
  uint32_t type = 0;  // pointee for pointers, element for arrays, component for vectors
  std::vector<uint32_t> members;
  std::vector<std::string> member_names;
  std::vector<uint32_t> member_offsets;
  std::vector<bool> member_nonwritable;
  uint32_t width = 0, signedness = 0, count = 0;
  uint32_t value = 0;  // an integer constant's (array lengths)
  uint32_t set = 0, binding = 0, array_stride = 0;
  bool has_binding = false, nonwritable = false, block = false;
};

std::string read_string(const uint32_t* words, size_t max_words) {
  const char* s = reinterpret_cast<const char*>(words);
  return std::string(s, strnlen(s, max_words * 4));
}

template <class T>
void ensure(std::vector<T>& v, uint32_t i) { if (v.size() <= i) v.resize(i + 1); }

// a buffer's element type (`type` the runtime array's element) into `b`
void describe_element(const std::vector<Id>& ids, uint32_t type, ReflectedBinding& b) {
  const Id* t = &ids[type];
  if (t->opcode == SpvOpTypeStruct) {
    b.element_type = t->name.empty() ? "struct" : t->name;
    return;
  }
  b.element_components = 1;
  if (t->opcode == SpvOpTypeVector) b.element_components = t->count, t = &ids[t->type];
  if (t->opcode != SpvOpTypeFloat && t->opcode != SpvOpTypeInt) return;
  b.element_kind = t->opcode == SpvOpTypeFloat ? ScalarKind::FLOAT : t->signedness ? ScalarKind::INT : ScalarKind::UINT;
  b.element_bits = t->width;
  const char* scalar = b.element_kind == ScalarKind::FLOAT ? (t->width == 64 ? "double" : t->width == 16 ? "half" : "float")
                       : b.element_kind == ScalarKind::INT ? (t->width == 64 ? "int64_t" : "int")
                                                           : (t->width == 64 ? "uint64_t" : "uint");
  b.element_type = scalar + (b.element_components > 1 ? std::to_string(b.element_components) : "");
}

// a group-memory type's size in bytes: scalars, vectors, arrays and structs of them, unpadded
uint64_t natural_size(const std::vector<Id>& ids, uint32_t type) {
  const Id& t = ids[type];
  switch (t.opcode) {
    case SpvOpTypeInt:
    case SpvOpTypeFloat: return t.width / 8;
    case SpvOpTypeVector: return t.count * natural_size(ids, t.type);
    case SpvOpTypeArray: return uint64_t(ids[t.count].value) * natural_size(ids, t.type);
    case SpvOpTypeStruct: {
      uint64_t bytes = 0;
      for (uint32_t m : t.members) bytes += natural_size(ids, m);
      return bytes;
    }
    default: return 4;  // a bool
  }
}

}  // namespace

const ReflectedBinding* ShaderReflection::find_binding(const std::string& name) const {
  for (auto& b : bindings) if (b.name == name) return &b;
  return nullptr;
}

const ReflectedConstant* ShaderReflection::find_constant(const std::string& name) const {
  for (auto& c : constants) if (c.name == name) return &c;
  return nullptr;
}

ShaderReflection reflect_spirv(const std::vector<uint32_t>& code) {
  if (code.size() < 5 || code[0] != SpvMagicNumber) throw std::runtime_error("not a SPIR-V module");
  std::vector<Id> ids(code[3]);
  ShaderReflection out;
  for (size_t i = 5; i < code.size();) {
    const uint32_t op = code[i] & 0xffff, n = code[i] >> 16;
    if (n == 0 || i + n > code.size()) throw std::runtime_error("malformed SPIR-V");
    const uint32_t* w = &code[i];
    switch (op) {
      case SpvOpName: ids[w[1]].name = read_string(w + 2, n - 2); break;
      case SpvOpMemberName: {
        Id& s = ids[w[1]];
        ensure(s.member_names, w[2]);
        s.member_names[w[2]] = read_string(w + 3, n - 3);
        break;
      }
      case SpvOpExecutionMode:
        if (w[2] == SpvExecutionModeLocalSize) out.local_size = {w[3], w[4], w[5]};
        break;
      case SpvOpDecorate:
        if (w[2] == SpvDecorationDescriptorSet) ids[w[1]].set = w[3];
        if (w[2] == SpvDecorationBinding) ids[w[1]].binding = w[3], ids[w[1]].has_binding = true;
        if (w[2] == SpvDecorationArrayStride) ids[w[1]].array_stride = w[3];
        if (w[2] == SpvDecorationNonWritable) ids[w[1]].nonwritable = true;
        if (w[2] == SpvDecorationBlock) ids[w[1]].block = true;
        break;
      case SpvOpMemberDecorate: {
        Id& s = ids[w[1]];
        if (w[3] == SpvDecorationOffset) { ensure(s.member_offsets, w[2]); s.member_offsets[w[2]] = w[4]; }
        if (w[3] == SpvDecorationNonWritable) { ensure(s.member_nonwritable, w[2]); s.member_nonwritable[w[2]] = true; }
        break;
      }
      case SpvOpTypeInt: ids[w[1]].opcode = op, ids[w[1]].width = w[2], ids[w[1]].signedness = w[3]; break;
      case SpvOpTypeFloat: ids[w[1]].opcode = op, ids[w[1]].width = w[2]; break;
      case SpvOpTypeVector: ids[w[1]].opcode = op, ids[w[1]].type = w[2], ids[w[1]].count = w[3]; break;
      case SpvOpTypeRuntimeArray: ids[w[1]].opcode = op, ids[w[1]].type = w[2]; break;
      case SpvOpTypeArray: ids[w[1]].opcode = op, ids[w[1]].type = w[2], ids[w[1]].count = w[3]; break;
      case SpvOpConstant: ids[w[2]].opcode = op, ids[w[2]].value = w[3]; break;
      case SpvOpTypeStruct:
        ids[w[1]].opcode = op;
        ids[w[1]].members.assign(w + 2, w + n);
        break;
      case SpvOpTypePointer: ids[w[1]].opcode = op, ids[w[1]].storage_class = w[2], ids[w[1]].type = w[3]; break;
      case SpvOpVariable: ids[w[2]].opcode = op, ids[w[2]].type = w[1], ids[w[2]].storage_class = w[3]; break;
      default: break;
    }
    i += n;
  }

  for (Id& var : ids) {
    if (var.opcode != SpvOpVariable) continue;
    const Id& pointee = ids[ids[var.type].type];
    if (var.storage_class == SpvStorageClassWorkgroup) {
      out.workgroup_bytes += uint32_t(natural_size(ids, ids[var.type].type));
    } else if (var.storage_class == SpvStorageClassPushConstant) {
      for (size_t m = 0; m < pointee.members.size(); ++m) {
        ReflectedConstant c;
        c.name = m < pointee.member_names.size() ? pointee.member_names[m] : "";
        c.offset = m < pointee.member_offsets.size() ? pointee.member_offsets[m] : 0;
        const Id* t = &ids[pointee.members[m]];
        if (t->opcode == SpvOpTypeVector) c.components = t->count, t = &ids[t->type];
        c.kind = t->opcode == SpvOpTypeFloat ? ScalarKind::FLOAT : t->signedness ? ScalarKind::INT : ScalarKind::UINT;
        c.size = (t->width / 8) * c.components;
        out.constants.push_back(c);
        out.push_constant_size = std::max(out.push_constant_size, c.offset + c.size);
      }
    } else if ((var.storage_class == SpvStorageClassStorageBuffer || var.storage_class == SpvStorageClassUniform) &&
               var.has_binding) {
      ReflectedBinding b;
      b.name = var.name.empty() ? pointee.name : var.name;
      // a Uniform-class Block is a cbuffer (or HLSL's implicit $Global): only storage buffers here
      if (var.storage_class == SpvStorageClassUniform && pointee.block)
        throw std::runtime_error("constant buffer '" + (b.name.empty() ? pointee.name : b.name) +
                                 "' is not supported: declare scalars in a [[vk::push_constant]] "
                                 "ConstantBuffer<T>, arrays as StructuredBuffer");
      b.set = var.set;
      b.binding = var.binding;
      b.writable = !(var.nonwritable || (!pointee.member_nonwritable.empty() && pointee.member_nonwritable[0]));
      if (!pointee.members.empty()) {
        const Id& array = ids[pointee.members[0]];
        b.stride = array.array_stride;
        describe_element(ids, array.type, b);
      }
      out.bindings.push_back(b);
    }
  }
  return out;
}

}  // namespace cressim::gpu
