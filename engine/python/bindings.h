// One function per area, called from module.cpp in order.
#pragma once
#include <pybind11/pybind11.h>

namespace cressim::python {
void bind_errors(pybind11::module_& m);
void bind_scene(pybind11::module_& m);
void bind_compute(pybind11::module_& m);
void bind_runtime(pybind11::module_& m);
void bind_particles(pybind11::module_& m);  // after bind_scene and bind_runtime: adds to Entity and Engine
}  // namespace cressim::python
