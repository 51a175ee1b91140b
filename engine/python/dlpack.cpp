#include "python/dlpack.h"

namespace cressim::python {
namespace {

struct Holder {
  std::shared_ptr<compute::TypedBuffer> buffer;
  std::vector<int64_t> shape;
  DLManagedTensor tensor;
};

void delete_holder(DLManagedTensor* t) { delete static_cast<Holder*>(t->manager_ctx); }

}  // namespace

pybind11::capsule make_dlpack_capsule(std::shared_ptr<compute::TypedBuffer> buffer, void* data, DLDevice device) {
  auto* h = new Holder{buffer, buffer->shape, {}};
  const auto info = compute::dtype_info(buffer->dtype);
  h->tensor.dl_tensor = {data, device, int32_t(h->shape.size()), {info.dlpack_code, uint8_t(info.size * 8), 1},
                         h->shape.data(), nullptr /* compact row-major */, 0};
  h->tensor.manager_ctx = h;
  h->tensor.deleter = delete_holder;
  // a consumer renames the capsule to "used_dltensor" and owns the tensor; otherwise free it here
  return pybind11::capsule(&h->tensor, "dltensor", [](PyObject* cap) {
    if (PyCapsule_IsValid(cap, "dltensor")) {
      auto* t = static_cast<DLManagedTensor*>(PyCapsule_GetPointer(cap, "dltensor"));
      if (t && t->deleter) t->deleter(t);
    }
  });
}

}  // namespace cressim::python
