// cressim._core: a thin binding over the C++ engine; the Python package adds the conveniences.
#include "python/bindings.h"

PYBIND11_MODULE(_core, m) {
  m.doc() = "CRESSim engine core (Vulkan); use the cressim package rather than this module";
  cressim::python::bind_errors(m);
  cressim::python::bind_scene(m);
  cressim::python::bind_compute(m);
  cressim::python::bind_runtime(m);
  cressim::python::bind_particles(m);
}
