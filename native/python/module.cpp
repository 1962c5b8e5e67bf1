// Python module `ptir`: the engine's data and renders as numpy arrays.
// Long calls release the GIL; engine errors arrive as ptir.Error (a RuntimeError).
// One bind_*.cpp per concept adds its part to the module.
#include <pybind11/pybind11.h>

#include "ptir/core/error.h"

namespace py = pybind11;

void bind_geometry(py::module_& m);  // GaussianField, TriangleMesh, Camera and their files
void bind_scene(py::module_& m);     // Scene: path tracer, renders, scene files
void bind_image(py::module_& m);     // read_image / write_image
void bind_losses(py::module_& m);    // ptir.losses
void bind_optimize(py::module_& m);  // Dataset, Optimizer, optimize
void bind_eval(py::module_& m);      // ptir.metrics, evaluate
void bind_pipeline(py::module_& m);  // optimize_pipeline: the stages of `ptir optimize`

PYBIND11_MODULE(ptir, m) {
  m.doc() = "PTIR: path-traced inverse rendering of 3D Gaussian splats";
  static py::exception<ptir::Error> error_type(m, "Error", PyExc_RuntimeError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const ptir::Error& e) {
      error_type(e.what());
    } catch (const ptir::Cancelled& e) {
      PyErr_SetString(PyExc_KeyboardInterrupt, "cancelled");
    }
  });
  bind_geometry(m);
  bind_scene(m);
  bind_image(m);
  bind_losses(m);
  bind_optimize(m);
  bind_eval(m);
  bind_pipeline(m);
}
