// gimm.Matcher: the learned matcher (match/learned.hpp) and its shipped weights, a file of its
// own so that a change to the gating or the network recompiles only it.
#include <pybind11/stl.h>

#include <cstdlib>
#include <filesystem>

#include "common.hpp"
#include "gimm/match/learned.hpp"
#include "gimm/nn/matcher_file.hpp"
#include "gimm/nn/shipped_weights.hpp"

namespace gimm::python {

namespace {

/// The shipped weights (nn/shipped_weights.hpp): after $GIMM_WEIGHTS, beside the package (a
/// wheel's gimm/weights/); an install tree's share/gimm/weights above the package; the source
/// tree it was built from.
std::string default_weights() {
  namespace fs = std::filesystem;
  const py::module_ self = py::module_::import("gimm._gimm");
  const fs::path package = fs::path(self.attr("__file__").cast<std::string>()).parent_path();
  std::vector<fs::path> dirs{package / "weights"};
  for (fs::path dir = package; dir.has_parent_path() && dir != dir.parent_path();
       dir = dir.parent_path())
    if (fs::is_directory(dir / "share" / "gimm" / "weights")) {
      dirs.push_back(dir / "share" / "gimm" / "weights");
      break;
    }
#ifdef GIMM_SOURCE_WEIGHTS_DIR
  dirs.emplace_back(GIMM_SOURCE_WEIGHTS_DIR);
#endif
  return nn::find_shipped_weights(dirs);
}

}  // namespace

void bind_learned(py::module_& m) {
  m.def(
      "network_image",
      [](const py::handle& image, const std::string& input) {
        Image<float> in = image_from<float>(image, Accept::real, "image");
        const NetworkImage kind = network_image_kind(input);
        Image<float> out;
        {
          py::gil_scoped_release release;
          out = network_image(in, kind);
        }
        return adopt_image(std::move(out));
      },
      py::arg("image"), py::arg("input"), R"doc(
What the learned matcher's network sees of an image already at the network's size
(match/network_input.hpp): input 'intensity' returns it as float32, 'vesselness' returns
1 - sqrt(vesselness) of its background-free log. tools/train calls this on every augmented
image, so training and gimm-match see the same thing.)doc");
  py::class_<nn::Matcher>(m, "Matcher", R"doc(
The GIMM learned matcher on gimm's CPU inference engine (match/learned.hpp, docs/matcher.md).

Matcher(weights=None): weights is a .safetensors file written by tools/train (gimm-matcher);
None: the shipped weights (weights/gimm-phantom-128.safetensors, trained on phantoms only),
looked for at $GIMM_WEIGHTS, in the package, in an install tree's share/gimm/weights and in the
source tree the module was built from. Raises gimm.IoError / gimm.FormatError naming the file.)doc")
      .def(py::init([](const py::object& weights) {
             const std::string path =
                 weights.is_none() ? default_weights() : py::str(weights).cast<std::string>();
             py::gil_scoped_release release;
             return std::make_unique<nn::Matcher>(nn::load_matcher(path));
           }),
           py::arg("weights") = py::none())
      .def_property_readonly(
          "input_size", [](const nn::Matcher& n) { return n.config().input_size; },
          "The longer image side (px) the weights were trained at; 0: not recorded")
      .def_property_readonly(
          "input", [](const nn::Matcher& n) { return n.config().input; },
          "What the network sees of an image: 'intensity' or 'vesselness' (gimm.network_image)")
      .def(
          "match",
          [](const nn::Matcher& net, const py::handle& image_a, const py::handle& image_b,
             int class_a, int class_b, const py::object& camera_a, const py::object& camera_b,
             const py::object& gate, double tau, const py::object& delta_px, int top_k,
             int min_matches, const py::object& input_size, const py::object& snap_to_epipolar,
             const py::object& field_a, const py::object& field_b) {
            const Image<float> a = image_from<float>(image_a, Accept::floating, "image_a");
            const Image<float> b = image_from<float>(image_b, Accept::floating, "image_b");
            std::optional<Camerad> ca, cb;
            if (!camera_a.is_none()) ca = camera_of(camera_a, "camera_a");
            if (!camera_b.is_none()) cb = camera_of(camera_b, "camera_b");
            MatchOptions o;
            o.gate.tau = tau;
            o.gate.top_k = top_k;
            o.gate.min_matches = min_matches;
            o.input_size = input_size.is_none() ? net.config().input_size : input_size.cast<int>();
            GateChoice chosen;  // None: what the weights record (as gimm-match without the flag)
            if (!gate.is_none()) chosen.mode = parse_gate_mode(gate.cast<std::string>());
            if (!delta_px.is_none()) chosen.delta_px = delta_px.cast<double>();
            if (!snap_to_epipolar.is_none()) chosen.snap = snap_to_epipolar.cast<bool>();
            apply_gate_choice(net.config(), chosen, o);
            PairInput input;
            input.image_a = &a;
            input.image_b = &b;
            input.class_a = class_a;
            input.class_b = class_b;
            input.camera_a = ca;
            input.camera_b = cb;
            const auto fa = optional_field(field_a, a, "field_a");
            const auto fb = optional_field(field_b, b, "field_b");
            input.field_a = fa ? &*fa : nullptr;
            input.field_b = fb ? &*fb : nullptr;
            PairMatchResult r;
            {
              py::gil_scoped_release release;
              r = match_pair(net, input, o);
            }
            return result_dict(std::move(r));
          },
          py::arg("image_a"), py::arg("image_b"), py::arg("class_a") = 0, py::arg("class_b") = 0,
          py::arg("camera_a") = py::none(), py::arg("camera_b") = py::none(), py::kw_only(),
          py::arg("gate") = py::none(), py::arg("tau") = 2.0, py::arg("delta_px") = py::none(),
          py::arg("top_k") = 256, py::arg("min_matches") = 32, py::arg("input_size") = py::none(),
          py::arg("snap_to_epipolar") = py::none(), py::arg("field_a") = py::none(),
          py::arg("field_b") = py::none(), R"doc(
Matches coronary points between two angiograms, as gimm-match does for one pair.

image_a, image_b: float (rows, cols) in [0, 1], bright background and dark vessels (render()'s
'intensity', or read_png); sizes may differ. class_a, class_b: view classes 1..11 (0 unknown;
view_class_from_angles). camera_a, camera_b: both or neither (Camera or CArm); with them the gate
uses their exact F, without it F is estimated from the matches (gate_reference). gate: 'hard'
(drops matches farther than delta_px from their epipolar lines), 'soft', 'logit' (rescale by
tau), 'none'. gate, delta_px, snap_to_epipolar (move B points onto their epipolar lines):
None takes what the weights record (the shipped ones: 'hard', 4 px, snapping), else 'hard',
2 px, no snapping, as gimm-match without those flags. input_size: the longer side the images are
resized to, None: the weights' (gimm-match's default), 0: the images' own size. field_a,
field_b: the exposed fields (nonzero = exposed, each its image's size; exposed_field finds them),
matches with an end outside are dropped; None: the whole image.
Returns the result every matcher returns (match_geometric too): dict(points_a, points_b (N, 2)
pixels (u, v) with centres at integers, confidence (N,), F (3, 3) with x_b^T F x_a = 0 or None,
F_source 'cameras' | 'matches' | 'none', candidates (the network's matches), dropped_in_padding,
dropped_by_gate, dropped_outside_field, seconds). The images are copied into gimm's storage; the
GIL is released while matching.)doc");
}

}  // namespace gimm::python
