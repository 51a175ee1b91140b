// The DLPack exchange structs (the ABI of dmlc/dlpack: legacy "dltensor" and 1.0
// "dltensor_versioned" capsules), and capsules over engine buffers that keep the buffer alive
// until the consumer lets go. Only versioned capsules can say "read-only", and numpy 2 marks
// arrays from legacy ones read-only, so versioned is used whenever the consumer accepts it.
#pragma once
#include <cstdint>
#include <memory>
#include <vector>

#include <pybind11/pybind11.h>

#include "compute/typed_buffer.h"

namespace cressim::python {

enum DLDeviceKind : int32_t { kDLCPU = 1, kDLCUDA = 2 };

struct DLDevice {
  int32_t device_type;
  int32_t device_id;
};
struct DLDataType {
  uint8_t code;
  uint8_t bits;
  uint16_t lanes;
};
struct DLTensor {
  void* data;
  DLDevice device;
  int32_t ndim;
  DLDataType dtype;
  int64_t* shape;
  int64_t* strides;
  uint64_t byte_offset;
};
struct DLManagedTensor {
  DLTensor dl_tensor;
  void* manager_ctx;
  void (*deleter)(DLManagedTensor*);
};
struct DLPackVersion {
  uint32_t major;
  uint32_t minor;
};
constexpr uint64_t kDLFlagReadOnly = 1;
struct DLManagedTensorVersioned {
  DLPackVersion version;
  void* manager_ctx;
  void (*deleter)(DLManagedTensorVersioned*);
  uint64_t flags;
  DLTensor dl_tensor;
};

// A capsule describing `buffer` at `data` on `device`; the buffer lives until the tensor dies.
// `versioned`: a DLPack 1.0 capsule (read-only flag set for engine-internal buffers).
pybind11::capsule make_dlpack_capsule(std::shared_ptr<compute::TypedBuffer> buffer, void* data, DLDevice device,
                                      bool versioned);

}  // namespace cressim::python
