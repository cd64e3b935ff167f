// The gimm Python module: errors, threads, version; the rest in geometry.cpp, volumes.cpp and
// match.cpp (docs/python.md).
#include <omp.h>

#include "common.hpp"
#include "gimm/core/error.hpp"
#include "gimm/core/parallel.hpp"
#include "gimm/version.hpp"

namespace py = pybind11;

PYBIND11_MODULE(_gimm, m) {
  m.doc() =
      "gimm: synthetic coronary angiography and multi-view matching (C++ core, numpy in and "
      "out).\n\n"
      "Conventions (docs/conventions.md, docs/python.md):\n"
      "- World: patient LPS millimetres (+x patient left, +y posterior, +z head).\n"
      "- Images: numpy (rows, cols), row-major; pixel (row i, col j) has its centre at\n"
      "  (u, v) = (j, i): point arrays are (N, 2) of (u, v) = (column, row).\n"
      "- Volumes: numpy (nx, ny, nz) indexed [i, j, k], Fortran order (i fastest) as NIfTI, with "
      "a\n"
      "  geometry dict: spacing (mm), origin (world mm of voxel (0, 0, 0)), direction (columns =\n"
      "  world axes of i, j, k).\n"
      "- Fundamental matrices: x_b^T F x_a = 0 (F maps points of A to epipolar lines in B).\n"
      "- C-arm angles: primary > 0 LAO, < 0 RAO; secondary > 0 cranial, < 0 caudal (degrees).\n"
      "Outputs of rendering, volume reading and the phantom are numpy views of gimm's own buffers\n"
      "(no copy; array.base is the owning capsule). Inputs are copied into gimm's storage.";
  m.attr("__version__") = GIMM_VERSION_STRING;

  // gimm::Error and its subclasses as Python exceptions with the same message. IoError is also
  // an OSError, FormatError also a ValueError, so generic handlers catch them too.
  static py::exception<gimm::Error> error(m, "Error", PyExc_RuntimeError);
  static py::exception<gimm::IoError> io_error(m, "IoError",
                                               py::make_tuple(error, py::handle(PyExc_OSError)));
  static py::exception<gimm::FormatError> format_error(
      m, "FormatError", py::make_tuple(error, py::handle(PyExc_ValueError)));
  for (py::handle cls : {py::handle(error), py::handle(io_error), py::handle(format_error)})
    cls.attr("__module__") = "gimm";
  error.doc() = "Every error gimm raises (gimm::Error); the message names the input and value.";
  io_error.doc() = "A file could not be opened, read or written (gimm::IoError); also an OSError.";
  format_error.doc() =
      "A file was read but its content is malformed (gimm::FormatError); also a ValueError.";
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const gimm::IoError& e) {
      PyErr_SetString(io_error.ptr(), e.what());
    } catch (const gimm::FormatError& e) {
      PyErr_SetString(format_error.ptr(), e.what());
    } catch (const gimm::Error& e) {
      PyErr_SetString(error.ptr(), e.what());
    }
  });

  m.def(
      "set_num_threads",
      [](int n) {
        // libgomp aborts the process when asked for a billion threads at the next parallel
        // region; more than 1024 is a mistake on any machine gimm runs on.
        if (n < 1 || n > 1024)
          throw py::value_error("set_num_threads: n must be in [1, 1024], got " +
                                std::to_string(n));
        omp_set_num_threads(n);
      },
      py::arg("n"),
      "Threads (OpenMP) that gimm's parallel loops use from now on, for calls made from the\n"
      "calling Python thread (OpenMP keeps the setting per thread; OMP_NUM_THREADS sets the\n"
      "default for all). Results do not depend on the thread count.");
  m.def("get_num_threads", &gimm::max_threads,
        "Threads gimm's parallel loops use for calls from this Python thread.");

  gimm::python::bind_geometry(m);
  gimm::python::bind_epipolar(m);
  gimm::python::bind_volumes(m);
  gimm::python::bind_render(m);
  gimm::python::bind_learned(m);
  gimm::python::bind_match(m);
  gimm::python::bind_geometric(m);
  gimm::python::bind_dataset(m);
#ifdef GIMM_PYTHON_HAVE_DICOM
  gimm::python::bind_dicom(m);
#endif
}
