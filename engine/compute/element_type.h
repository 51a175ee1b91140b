// Whether a typed buffer holds the elements an HLSL buffer declares: a float buffer bound as
// StructuredBuffer<float4> would otherwise read past its end, an int buffer bound as float
// would read garbage. Checked whenever a pass, built-in or custom, binds its buffers.
#pragma once
#include <string>

#include "compute/typed_buffer.h"
#include "gpu/spirv_reflect.h"

namespace cressim::compute {

// Throws BindingError naming the pass, the binding and both types when `buffer` cannot be read
// as an array of the binding's elements: float elements need a float buffer of that width,
// integer ones an integer buffer; and each row of the buffer (its trailing dimensions) must hold
// whole elements, so a float4 element wants a (n, 4) float32 buffer, not (4n,).
void check_element_type(const std::string& pass, const gpu::ReflectedBinding& binding, const TypedBuffer& buffer);

}  // namespace cressim::compute
