#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "compute/compute_pass.h"
#include "compute/cuda_interop.h"
#include "gpu/context.h"
#include "gpu/readback_batch.h"
#include "python/bindings.h"
#include "python/dlpack.h"

namespace py = pybind11;

namespace cressim::python {
namespace {

using compute::TypedBuffer;

py::dtype numpy_dtype(compute::DType t) { return py::dtype(compute::dtype_info(t).name); }

py::array read(const TypedBuffer& b) {
  py::array out(numpy_dtype(b.dtype), std::vector<py::ssize_t>(b.shape.begin(), b.shape.end()));
  void* dst = out.mutable_data();
  // a large readback (a batch of camera images) takes long: other Python threads (the twin's
  // control tick) run meanwhile; the engine itself is not thread-safe, callers serialise its use
  py::gil_scoped_release release;
  gpu::readback(*b.storage->ctx, b.storage->buffer, dst, b.bytes());
  return out;
}

void write(TypedBuffer& b, py::object values) {
  if (b.read_only) throw py::value_error("buffer " + b.describe() + " is the engine's; it is read-only");
  py::array a = py::module_::import("numpy").attr("ascontiguousarray")(values);
  if (!a.dtype().is(numpy_dtype(b.dtype))) a = a.attr("astype")(numpy_dtype(b.dtype));
  if (uint64_t(a.size()) != b.elements())
    throw py::value_error("write to " + b.describe() + ": got " + std::to_string(a.size()) + " elements, need " +
                          std::to_string(b.elements()));
  gpu::upload(*b.storage->ctx, b.storage->buffer, a.data(), b.bytes());
}

// host-visible memory goes out as CPU memory; device memory as CUDA memory where the driver
// can import it (the data is ready: end_frame() has waited for the frame)
py::capsule to_dlpack(std::shared_ptr<TypedBuffer> b, py::object max_version) {
  const bool versioned = !max_version.is_none() && py::tuple(max_version)[0].cast<int>() >= 1;
  if (b->host_visible()) return make_dlpack_capsule(b, b->storage->buffer.mapped, {kDLCPU, 0}, versioned);
  try {
    const auto& m = b->cuda_mapping();
    return make_dlpack_capsule(b, reinterpret_cast<void*>(m.pointer), {kDLCUDA, m.device}, versioned);
  } catch (const std::exception& e) {
    throw py::buffer_error("buffer " + b->describe() + " cannot be shared without a copy (" + e.what() +
                           "); use .read()");
  }
}

py::tuple dlpack_device(std::shared_ptr<TypedBuffer> b) {
  if (b->host_visible()) return py::make_tuple(int(kDLCPU), 0);
  try {
    return py::make_tuple(int(kDLCUDA), b->cuda_mapping().device);
  } catch (const std::exception& e) {
    throw py::buffer_error("buffer " + b->describe() + " cannot be shared without a copy (" + e.what() + ")");
  }
}

// buffers -> the caller's numpy arrays (C-contiguous, each the size of its buffer), one submit
// for all: a sensor frame's images come back together; the arrays can be reused frame to frame
void read_buffers(const std::vector<std::shared_ptr<TypedBuffer>>& buffers, const std::vector<py::array>& outs) {
  if (buffers.size() != outs.size())
    throw py::value_error("read_buffers: " + std::to_string(buffers.size()) + " buffers but " +
                          std::to_string(outs.size()) + " arrays");
  std::vector<gpu::ReadbackItem> items;
  std::shared_ptr<gpu::Context> ctx;
  for (size_t i = 0; i < buffers.size(); ++i) {
    const auto& b = *buffers[i];
    py::array a = outs[i];
    if (!(a.flags() & py::array::c_style) || !a.writeable())
      throw py::value_error("read_buffers: the array for " + b.describe() + " is not a writeable C-contiguous array");
    if (uint64_t(a.nbytes()) != b.bytes())
      throw py::value_error("read_buffers: the array for " + b.describe() + " has " + std::to_string(a.nbytes()) +
                            " bytes, the buffer " + std::to_string(b.bytes()));
    if (ctx && b.storage->ctx != ctx) throw py::value_error("read_buffers: the buffers belong to different engines");
    ctx = b.storage->ctx;
    items.push_back({&b.storage->buffer, a.mutable_data(), b.bytes()});
  }
  if (!ctx) return;
  py::gil_scoped_release release;  // the copy and the wait run while the control tick runs Python
  gpu::readback_batch(*ctx, items);
}

}  // namespace

void bind_compute(py::module_& m) {
  m.def("read_buffers", &read_buffers, py::arg("buffers"), py::arg("out"),
        "Copies each buffer into its array (C-contiguous, the buffer's size in bytes) in one submit.");
  py::class_<TypedBuffer, std::shared_ptr<TypedBuffer>>(m, "Buffer",
                                                        "A GPU buffer: a shared buffer or an engine-internal one.")
      .def_property_readonly("key", [](const TypedBuffer& b) { return b.key; })
      .def_property_readonly("shape", [](const TypedBuffer& b) { return py::tuple(py::cast(b.shape)); })
      .def_property_readonly("dtype", [](const TypedBuffer& b) { return numpy_dtype(b.dtype); })
      .def_property_readonly("nbytes", &TypedBuffer::bytes)
      .def_property_readonly("read_only", [](const TypedBuffer& b) { return b.read_only; })
      .def_property_readonly("host_visible", &TypedBuffer::host_visible,
                             "True when numpy/torch can view the memory without a copy.")
      .def("read", &read, "A numpy copy of the contents.")
      .def("write", &write, py::arg("values"), "Copies values (any array of the right size) into the buffer.")
      .def_property_readonly("cuda_shareable", [](const TypedBuffer& b) {
             return b.storage->buffer.exportable &&
                    compute::cuda_unavailable_reason(*b.storage->ctx).empty();
           }, "True when torch can view the buffer as CUDA memory without a copy.")
      .def("numpy", [](std::shared_ptr<TypedBuffer> b) -> py::object {
             if (b->host_visible()) return py::module_::import("numpy").attr("from_dlpack")(py::cast(b));
             return read(*b);
           },
           "A zero-copy view where the memory is host-visible, else a copy.")
      .def("__dlpack__",
           [](std::shared_ptr<TypedBuffer> b, py::object, py::object max_version, py::object, py::object) {
             return to_dlpack(b, max_version);
           },
           py::kw_only(), py::arg("stream") = py::none(), py::arg("max_version") = py::none(),
           py::arg("dl_device") = py::none(), py::arg("copy") = py::none())
      .def("__dlpack_device__", &dlpack_device)
      .def("__repr__", [](const TypedBuffer& b) {
        return "<Buffer " + b.describe() + (b.read_only ? " read-only" : "") + ">";
      });

  py::class_<compute::ComputePass, std::shared_ptr<compute::ComputePass>>(m, "ComputePass")
      .def_property_readonly("name", [](const compute::ComputePass& p) { return p.name; })
      .def_property_readonly("groups", [](const compute::ComputePass& p) { return p.groups; })
      .def_property_readonly("local_size", [](const compute::ComputePass& p) { return p.pipeline.reflection.local_size; })
      .def_property_readonly("bindings", [](const compute::ComputePass& p) {
        py::dict d;
        for (auto& [name, b] : p.bindings) d[py::str(name)] = b;
        return d;
      })
      .def_property_readonly("constants", [](const compute::ComputePass& p) {
        std::vector<std::string> n;
        for (auto& c : p.pipeline.reflection.constants) n.push_back(c.name);
        return n;
      })
      .def("set_constant",
           [](compute::ComputePass& p, const std::string& name, py::object value) {
             if (py::isinstance<py::sequence>(value)) {
               const auto* c = p.pipeline.reflection.find_constant(name);
               std::string t = c && c->kind == gpu::ScalarKind::FLOAT ? (c->size / c->components == 8 ? "float64" : "float32")
                               : c && c->kind == gpu::ScalarKind::INT ? "int32" : "uint32";
               py::array a = py::array(value).attr("astype")(t);
               p.set_constant_bits(name, a.data(), size_t(a.nbytes()));
             } else {
               p.set_constant(name, value.cast<double>());
             }
           },
           py::arg("name"), py::arg("value"), "Sets a push constant by its HLSL member name.")
      .def("set_threads", [](compute::ComputePass& p, std::array<uint64_t, 3> t) { p.set_threads(t); })
      .def("__repr__", [](const compute::ComputePass& p) { return "<ComputePass '" + p.name + "'>"; });
}

}  // namespace cressim::python
