#include "python/dlpack.h"

namespace cressim::python {
namespace {

struct Holder {
  std::shared_ptr<compute::TypedBuffer> buffer;
  std::vector<int64_t> shape;
  DLManagedTensor legacy;
  DLManagedTensorVersioned versioned;
};

DLTensor describe(Holder& h, void* data, DLDevice device) {
  const auto info = compute::dtype_info(h.buffer->dtype);
  return {data, device, int32_t(h.shape.size()), {info.dlpack_code, uint8_t(info.size * 8), 1}, h.shape.data(),
          nullptr /* compact row-major */, 0};
}

// A consumer renames a capsule it takes ("used_...") and calls the deleter itself later;
// a capsule nobody took is freed here.
template <class T>
void free_unused(PyObject* cap, const char* name) {
  if (PyCapsule_IsValid(cap, name)) {
    auto* t = static_cast<T*>(PyCapsule_GetPointer(cap, name));
    if (t && t->deleter) t->deleter(t);
  }
}

}  // namespace

pybind11::capsule make_dlpack_capsule(std::shared_ptr<compute::TypedBuffer> buffer, void* data, DLDevice device,
                                      bool versioned) {
  auto* h = new Holder{buffer, buffer->shape, {}, {}};
  if (versioned) {
    h->versioned = {{1, 0}, h, [](DLManagedTensorVersioned* t) { delete static_cast<Holder*>(t->manager_ctx); },
                    buffer->read_only ? kDLFlagReadOnly : 0, describe(*h, data, device)};
    return pybind11::capsule(&h->versioned, "dltensor_versioned",
                             [](PyObject* cap) { free_unused<DLManagedTensorVersioned>(cap, "dltensor_versioned"); });
  }
  h->legacy = {describe(*h, data, device), h, [](DLManagedTensor* t) { delete static_cast<Holder*>(t->manager_ctx); }};
  return pybind11::capsule(&h->legacy, "dltensor",
                           [](PyObject* cap) { free_unused<DLManagedTensor>(cap, "dltensor"); });
}

}  // namespace cressim::python
