// A GPU buffer with a name, a shape and an element type: user shared buffers (read-write in
// custom passes) and the engine's internal buffers (read-only there) are both this.
#pragma once
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "compute/cuda_interop.h"
#include "gpu/buffer.h"

namespace cressim::compute {

enum class DType { NONE = 0, FLOAT32, INT32, UINT32, FLOAT64, UINT8 };

struct DTypeInfo {
  const char* name;
  uint32_t size;
  uint8_t dlpack_code;  // kDLInt 0, kDLUInt 1, kDLFloat 2
};

DTypeInfo dtype_info(DType t);
DType parse_dtype(const std::string& name);  // "float32", "f4", "int32", "uint32", "float64"

struct TypedBuffer {
  std::string key;               // shared buffer name, or internal key like "transform.positions"
  std::vector<int64_t> shape;    // element shape; float4 rows are (rows, 4)
  DType dtype = DType::NONE;
  bool read_only = false;        // internal buffers: custom passes may not write them
  uint64_t generation = 0;       // internal buffers: the upload_world() that made them
  std::shared_ptr<gpu::OwnedBuffer> storage;
  std::shared_ptr<CudaMapping> cuda;  // made on first CUDA view; released before storage

  // the buffer as a CUDA pointer (mapped once); throws when the device cannot share memory
  const CudaMapping& cuda_mapping();
  uint64_t elements() const;
  uint64_t bytes() const { return elements() * dtype_info(dtype).size; }
  bool host_visible() const { return storage && storage->buffer.mapped; }
  std::string describe() const;  // "'name' (64, 1000) float32"
};

std::shared_ptr<TypedBuffer> make_typed_buffer(std::shared_ptr<gpu::Context> ctx, std::string key,
                                               std::vector<int64_t> shape, DType dtype, bool read_only,
                                               bool exportable = false, gpu::Memory memory = gpu::Memory::DEVICE);

// The engine's buffers by key ("rigid.positions", "camera0.rgb", ...).
using BufferMap = std::map<std::string, std::shared_ptr<TypedBuffer>>;

// How every system makes its buffers: `key` in `into`, `bytes` of `data` uploaded (zeros
// without data), tagged with the upload_world() generation it belongs to.
std::shared_ptr<TypedBuffer> make_keyed_buffer(std::shared_ptr<gpu::Context> ctx, BufferMap& into, const std::string& key,
                                               const void* data, size_t bytes, std::vector<int64_t> shape, DType dtype,
                                               bool read_only, uint64_t generation, bool exportable = false);

template <class T>
std::shared_ptr<TypedBuffer> make_keyed_buffer(std::shared_ptr<gpu::Context> ctx, BufferMap& into, const std::string& key,
                                               const std::vector<T>& data, std::vector<int64_t> shape, DType dtype,
                                               bool read_only, uint64_t generation, bool exportable = false) {
  return make_keyed_buffer(std::move(ctx), into, key, data.empty() ? nullptr : data.data(), data.size() * sizeof(T),
                           std::move(shape), dtype, read_only, generation, exportable);
}

}  // namespace cressim::compute
