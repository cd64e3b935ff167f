// gimm.Dataset: a gimm-dataset folder read as gimm-match and gimm-eval read it
// (dataset/reader.hpp), pairs as the truth dicts evaluate() and match_baseline() take.
#include <filesystem>
#include <string>
#include <vector>

#include <pybind11/stl.h>

#include "common.hpp"
#include "gimm/dataset/reader.hpp"
#include "gimm/io/png.hpp"

namespace gimm::python {

void bind_dataset(py::module_& m) {
  py::class_<DatasetReader>(m, "Dataset", R"doc(
A gimm-dataset folder (docs/dataset.md), read as gimm-match and gimm-eval read it.

Dataset(path): checks the manifest. patients(split='all'), pair_ids(split='all'): ids in the
dataset's order ('<patient>/<pair>', e.g. 'phantom-0003/LCA_00-04'); split is 'all', 'train',
'val' or 'test'. pair(id): the pair's truth as a dict that evaluate() and match_baseline() take:
id, system, view_a, view_b (view names), view_class_a, view_class_b, F (3, 3) with
x_b^T F x_a = 0, points_a, points_b (N, 2) pixels (u, v) of the dense labels, world_mm (N, 3),
mask_a, mask_b (rows, cols) uint8 vessel masks. camera(patient, view): the view's Camera.
image(patient, view): the angiogram as float32 in [0, 1] (the 16-bit PNG / 65535, as gimm-match
reads it). manifest: the manifest as a dict.)doc")
      .def(py::init([](const std::filesystem::path& root) {
             py::gil_scoped_release release;
             return std::make_unique<DatasetReader>(root);
           }),
           py::arg("path"))
      .def("patients", &DatasetReader::patients, py::arg("split") = "all")
      .def("pair_ids", &DatasetReader::pair_ids, py::arg("split") = "all")
      .def(
          "pair",
          [](DatasetReader& r, const std::string& id) {
            PairTruth t;
            {
              py::gil_scoped_release release;
              t = r.pair(id);
            }
            py::dict d = truth_dict(t);
            d["system"] = t.system();
            d["view_a"] = t.view_a;
            d["view_b"] = t.view_b;
            d["view_class_a"] = t.view_class_a;
            d["view_class_b"] = t.view_class_b;
            return d;
          },
          py::arg("id"))
      .def("camera", &DatasetReader::camera, py::arg("patient"), py::arg("view"))
      .def(
          "image",
          [](const DatasetReader& r, const std::string& patient, const std::string& view) {
            Image<float> image;
            {
              py::gil_scoped_release release;
              image = read_png_unit(r.layout().view_image(patient, view));
            }
            return adopt_image(std::move(image));
          },
          py::arg("patient"), py::arg("view"))
      .def_property_readonly(
          "manifest",
          [](const DatasetReader& r) {
            return py::module_::import("json").attr("loads")(r.manifest().dump());
          })
      .def_property_readonly("root", [](const DatasetReader& r) { return r.root().string(); })
      .def("__repr__",
           [](const DatasetReader& r) { return "gimm.Dataset('" + r.root().string() + "')"; });
}

}  // namespace gimm::python
