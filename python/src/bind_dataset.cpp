// gimm.Dataset: a gimm-dataset folder read as gimm-match and gimm-eval read it
// (dataset/reader.hpp), pairs as the truth dicts evaluate() and match_baseline() take.
#include <filesystem>
#include <string>
#include <vector>

#include <pybind11/stl.h>

#include "common.hpp"
#include "gimm/dataset/reader.hpp"
#include "gimm/io/png.hpp"
#include "gimm/match/baselines.hpp"
#include "gimm/match/geometric.hpp"
#include "gimm/match/learned.hpp"
#include "gimm/pipeline/match_run.hpp"

namespace gimm::python {

namespace {

DatasetImages dataset_images(const std::string& images) {
  if (images == "auto") return DatasetImages::automatic;
  if (images == "rendered") return DatasetImages::rendered;
  if (images == "formed") return DatasetImages::formed;
  throw py::value_error("match_dataset: images must be 'auto', 'rendered' or 'formed', got '" +
                        images + "'");
}

/// The matcher match_dataset was given: a gimm.Matcher (learned, with the gate its weights
/// record), or a method's name with its options.
std::unique_ptr<PairMatcher> dataset_matcher(const py::object& matcher, const py::dict& options,
                                             std::uint64_t seed) {
  const auto take = [&](const char* key, auto fallback) {
    using T = decltype(fallback);
    if (!options.contains(key)) return fallback;
    T value = options[key].cast<T>();
    options.attr("pop")(key);
    return value;
  };
  std::unique_ptr<PairMatcher> out;
  if (py::isinstance<nn::Matcher>(matcher)) {
    const nn::Matcher& network = matcher.cast<const nn::Matcher&>();
    MatchOptions o;
    o.input_size = network.config().input_size;
    apply_gate_choice(network.config(), GateChoice{}, o);
    out = std::make_unique<LearnedMatcher>(network, o);
  } else {
    const std::string method = py::str(matcher).cast<std::string>();
    if (method == "geometric") {
      GeometricOptions o;
      o.use_masks = !take("segment", false);
      o.epipolar_tolerance_px = take("tolerance_px", o.epipolar_tolerance_px);
      if (take("keep_catheter", false)) o.catheter.min_length_mm = 0, o.catheter.field_edge_px = 0;
      out = std::make_unique<GeometricMatcher>(o);
    } else if (method == "oracle" || method == "epipolar") {
      EpipolarBaselineOptions o;
      const double sigma = method == "oracle" ? take("sigma_px", 1.0) : 1.0;
      if (method == "epipolar") o.max_points = take("max_points", o.max_points);
      out = options_checked("match_dataset", [&] { return baseline_matcher(method, sigma, o, seed); });
    } else {
      throw py::value_error(
          "match_dataset: matcher must be a gimm.Matcher or 'geometric', 'epipolar' or 'oracle', "
          "got '" + method + "'");
    }
  }
  if (!options.empty())  // an option of another matcher would be ignored: refuse it
    throw py::value_error("match_dataset: " + py::str(options.attr("keys")()).cast<std::string>() +
                          " are not options of the " + out->name() + " matcher");
  return out;
}

}  // namespace

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

  m.def(
      "match_dataset",
      [](const std::filesystem::path& dataset, const std::filesystem::path& out,
         const py::object& matcher, const std::string& split, const std::string& images,
         bool use_cameras, double camera_error_deg, double camera_error_mm, double noise_photons,
         double blur_px, std::uint64_t seed, const py::kwargs& kwargs) {
        py::dict options(kwargs);  // the matcher's own options, taken out as they are read
        const std::unique_ptr<PairMatcher> chosen = dataset_matcher(matcher, options, seed);
        MatchRunOptions run;
        run.split = split;
        run.images = dataset_images(images);
        run.use_cameras = use_cameras;
        run.camera_error = {camera_error_deg, camera_error_mm};
        run.degradation = {noise_photons, blur_px};
        run.seed = seed;
        MatchRunSummary summary;
        {
          py::gil_scoped_release release;
          summary = match_dataset(*chosen, dataset, out, run);
        }
        py::dict d;
        d["pairs"] = summary.pairs;
        d["matches"] = summary.matches;
        d["without_F"] = summary.without_F;
        d["formed"] = summary.formed;
        d["seconds"] = summary.seconds;
        return d;
      },
      py::arg("dataset"), py::arg("out"), py::arg("matcher"), py::kw_only(),
      py::arg("split") = "all", py::arg("images") = "auto", py::arg("use_cameras") = true,
      py::arg("camera_error_deg") = 0.0, py::arg("camera_error_mm") = 0.0,
      py::arg("noise_photons") = 0.0, py::arg("blur_px") = 0.0, py::arg("seed") = 0, R"doc(
Matches every pair of a gimm-dataset split into out/<patient>/<pair>.json (gimm-matches/1, what
gimm-eval and evaluate() score), as gimm-match --dataset does (pipeline/match_run.hpp): all or
nothing, a failed run leaves out as it was.

matcher: a gimm.Matcher (the learned matcher, with the gate and input size its weights record),
or 'geometric' (options: segment=False (True: segment the images instead of following the
dataset's masks), tolerance_px=3.0, keep_catheter=False), 'epipolar' (max_points=300) or
'oracle' (sigma_px=1.0); an option of another matcher raises ValueError. split: 'all', 'train',
'val', 'test'. images: 'auto' (formed views where the dataset has them), 'rendered', 'formed'.
use_cameras: give the matcher the views' cameras (False: the learned matcher estimates F from its
matches). camera_error_deg, camera_error_mm: move the matcher's cameras (stability sweeps);
noise_photons, blur_px: degrade the images it sees; seed: their random streams (and the
baselines'). Returns dict(pairs, matches, without_F, formed, seconds). The GIL is released.)doc");
}

}  // namespace gimm::python
