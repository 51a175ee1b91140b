#include "compute/element_type.h"

#include "compute/compute_pass.h"

namespace cressim::compute {

void check_element_type(const std::string& pass, const gpu::ReflectedBinding& b, const TypedBuffer& buffer) {
  const std::string where = "pass '" + pass + "', binding '" + b.name + "': the shader reads " + b.element_type +
                            " elements (" + std::to_string(b.stride) + " bytes each), but it is bound to " +
                            buffer.describe();
  const bool float_data = buffer.dtype == DType::FLOAT32 || buffer.dtype == DType::FLOAT64;
  const uint32_t bits = dtype_info(buffer.dtype).size * 8;
  if (b.element_kind == gpu::ScalarKind::FLOAT && !(float_data && bits == b.element_bits))
    throw BindingError(where + "; bind a float" + std::to_string(b.element_bits) + " buffer");
  if ((b.element_kind == gpu::ScalarKind::INT || b.element_kind == gpu::ScalarKind::UINT) && float_data)
    throw BindingError(where + "; bind an integer buffer (int32, uint32 or packed uint8)");
  // a row: the bytes of one index along the first dimension
  uint64_t row = dtype_info(buffer.dtype).size;
  for (size_t i = 1; i < buffer.shape.size(); ++i) row *= uint64_t(buffer.shape[i]);
  if (b.stride && row % b.stride) {
    std::string hint = "; its rows (" + std::to_string(row) + " bytes) must hold whole elements";
    if (b.element_components > 1 && b.element_bits == bits)
      hint += ": give it shape (n, " + std::to_string(b.stride * 8 / bits) + ")";
    throw BindingError(where + hint);
  }
}

}  // namespace cressim::compute
