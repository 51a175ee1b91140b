#include <pybind11/pybind11.h>

#include "compute/compute_pass.h"
#include "gpu/error.h"
#include "gpu/shader_compiler.h"
#include "python/bindings.h"
#include "runtime/engine.h"
#include "scene/authoring_error.h"

namespace py = pybind11;

namespace cressim::python {

void bind_errors(py::module_& m) {
  static py::exception<gpu::VulkanError> vulkan(m, "VulkanError", PyExc_RuntimeError);
  static py::exception<gpu::DeviceLostError> lost(m, "DeviceLostError", vulkan.ptr());
  static py::exception<gpu::ShaderCompileError> shader(m, "ShaderCompileError", PyExc_ValueError);
  static py::exception<compute::BindingError> binding(m, "BindingError", PyExc_LookupError);
  static py::exception<runtime::TopologyError> topology(m, "TopologyError", PyExc_RuntimeError);
  // a ValueError, as before it had a type; entity, env, field and source say where
  static py::exception<scene::AuthoringError> authoring(m, "AuthoringError", PyExc_ValueError);
  // most specific first
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const gpu::DeviceLostError& e) {
      py::set_error(lost, e.what());
    } catch (const gpu::VulkanError& e) {
      py::set_error(vulkan, e.what());
    } catch (const gpu::ShaderCompileError& e) {
      py::set_error(shader, e.what());
    } catch (const compute::BindingError& e) {
      py::set_error(binding, e.what());
    } catch (const runtime::TopologyError& e) {
      py::set_error(topology, e.what());
    } catch (const scene::AuthoringError& e) {
      py::object err = py::reinterpret_borrow<py::object>(authoring)(e.what());
      err.attr("entity") = e.entity;
      err.attr("env") = e.env;
      err.attr("field") = e.field;
      err.attr("source") = e.source;
      py::set_error(authoring, err);
    }
  });
}

}  // namespace cressim::python
