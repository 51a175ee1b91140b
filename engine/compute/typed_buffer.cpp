#include "compute/typed_buffer.h"

#include <stdexcept>

namespace cressim::compute {

DTypeInfo dtype_info(DType t) {
  switch (t) {
    case DType::FLOAT32: return {"float32", 4, 2};
    case DType::INT32: return {"int32", 4, 0};
    case DType::UINT32: return {"uint32", 4, 1};
    case DType::FLOAT64: return {"float64", 8, 2};
    case DType::UINT8: return {"uint8", 1, 1};
    default: return {"none", 0, 0};
  }
}

DType parse_dtype(const std::string& n) {
  if (n == "float32" || n == "f4" || n == "float" || n == "<f4") return DType::FLOAT32;
  if (n == "int32" || n == "i4" || n == "int" || n == "<i4") return DType::INT32;
  if (n == "uint32" || n == "u4" || n == "uint" || n == "<u4") return DType::UINT32;
  if (n == "float64" || n == "f8" || n == "double" || n == "<f8") return DType::FLOAT64;
  if (n == "uint8" || n == "u1" || n == "|u1") return DType::UINT8;
  throw std::invalid_argument("unsupported dtype '" + n + "': use float32, int32, uint32, float64 or uint8");
}

uint64_t TypedBuffer::elements() const {
  uint64_t n = 1;
  for (int64_t d : shape) n *= uint64_t(d);
  return n;
}

const CudaMapping& TypedBuffer::cuda_mapping() {
  if (!cuda) {
    if (!storage->buffer.exportable)
      throw std::runtime_error("buffer " + describe() + " was not allocated exportable for CUDA");
    cuda = map_to_cuda(*storage->ctx, storage->buffer);
  }
  return *cuda;
}

std::string TypedBuffer::describe() const {
  std::string s = "'" + key + "' (";
  for (size_t i = 0; i < shape.size(); ++i) s += (i ? ", " : "") + std::to_string(shape[i]);
  if (shape.size() == 1) s += ",";
  return s + ") " + dtype_info(dtype).name;
}

std::shared_ptr<TypedBuffer> make_typed_buffer(std::shared_ptr<gpu::Context> ctx, std::string key,
                                               std::vector<int64_t> shape, DType dtype, bool read_only,
                                               bool exportable, gpu::Memory memory) {
  auto b = std::make_shared<TypedBuffer>();
  b->key = std::move(key);
  b->shape = std::move(shape);
  b->dtype = dtype;
  b->read_only = read_only;
  for (int64_t d : b->shape)
    if (d < 0) throw std::invalid_argument("buffer '" + b->key + "': negative dimension in shape");
  if (dtype == DType::NONE) throw std::invalid_argument("buffer '" + b->key + "': no dtype");
  gpu::BufferOptions options;
  options.exportable = exportable;
  options.memory = memory;
  b->storage = std::make_shared<gpu::OwnedBuffer>(std::move(ctx), b->bytes(), options);
  return b;
}

std::shared_ptr<TypedBuffer> make_keyed_buffer(std::shared_ptr<gpu::Context> ctx, BufferMap& into, const std::string& key,
                                               const void* data, size_t bytes, std::vector<int64_t> shape, DType dtype,
                                               bool read_only, uint64_t generation, bool exportable) {
  auto b = make_typed_buffer(ctx, key, std::move(shape), dtype, read_only, exportable);
  b->generation = generation;
  if (data && bytes) gpu::upload(*ctx, b->storage->buffer, data, bytes);
  else gpu::fill(*ctx, b->storage->buffer, 0);
  into[key] = b;
  return b;
}

}  // namespace cressim::compute
