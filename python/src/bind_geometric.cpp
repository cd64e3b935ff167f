// gimm.match_geometric: the training-free geometric matcher (match/geometric.hpp), a file of
// its own so that the learned matcher's file does not compile it, nor it the network.
#include <pybind11/stl.h>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common.hpp"
#include "gimm/match/field_of_view.hpp"
#include "gimm/match/geometric.hpp"

namespace gimm::python {

void bind_geometric(py::module_& m) {
  m.def(
      "exposed_field",
      [](const py::handle& image) {
        Image<float> im = image_from<float>(image, Accept::floating, "image");
        Image<std::uint8_t> field;
        {
          py::gil_scoped_release release;
          field = exposed_field(im);
        }
        return adopt_image(std::move(field));
      },
      py::arg("image"), R"doc(
The exposed field of an angiogram (match/field_of_view.hpp): uint8 (rows, cols), 1 where the
collimator let X-rays through, 0 on its dark frame and penumbra (and 6 px further in). image:
float (rows, cols) in [0, 1], dark vessels and frame on a bright field; at least 16 x 16.
)doc");
  m.def(
      "match_geometric",
      [](const py::handle& image_a, const py::handle& image_b, const py::handle& camera_a,
         const py::handle& camera_b, const py::object& mask_a, const py::object& mask_b,
         double tolerance_px, bool exact_vesselness, const py::object& min_confidence,
         const py::object& field_a, const py::object& field_b, const py::object& detect,
         bool keep_catheter) {
        if (mask_a.is_none() != mask_b.is_none())
          throw py::value_error("match_geometric: give both mask_a and mask_b, or neither");
        const Image<float> a = image_from<float>(image_a, Accept::floating, "image_a");
        const Image<float> b = image_from<float>(image_b, Accept::floating, "image_b");
        std::optional<Image<std::uint8_t>> ma, mb;
        if (!mask_a.is_none()) {
          ma = image_from<std::uint8_t>(mask_a, Accept::mask, "mask_a");
          mb = image_from<std::uint8_t>(mask_b, Accept::mask, "mask_b");
        }
        PairInput input;
        input.image_a = &a;
        input.image_b = &b;
        input.camera_a = camera_of(camera_a, "camera_a");
        input.camera_b = camera_of(camera_b, "camera_b");
        input.mask_a = ma ? &*ma : nullptr;
        input.mask_b = mb ? &*mb : nullptr;
        // The exposed fields: given, else found when segmenting (as gimm-match does for a pair
        // of images), not with masks (as gimm-match --dataset, whose masks are the truth's).
        const bool find = detect.is_none() ? mask_a.is_none() : detect.cast<bool>();
        const auto field = [&](const py::object& given, const Image<float>& image,
                               const char* name) -> std::optional<Image<std::uint8_t>> {
          if (!given.is_none() || !find) return optional_field(given, image, name);
          return exposed_field(image);
        };
        const auto fa = field(field_a, a, "field_a"), fb = field(field_b, b, "field_b");
        input.field_a = fa ? &*fa : nullptr;
        input.field_b = fb ? &*fb : nullptr;
        GeometricOptions o;
        o.epipolar_tolerance_px = tolerance_px;
        o.segmentation.vesselness.exact_derivatives = exact_vesselness;
        if (keep_catheter) o.catheter.min_length_mm = 0, o.catheter.field_edge_px = 0;
        if (!min_confidence.is_none())  // whichever threshold the pair's mode uses
          o.min_confidence = o.min_confidence_segmented = min_confidence.cast<double>();
        // Working memory kept from call to call (about 25 MB at 512 px): a loop over pairs then
        // allocates it once, not per pair (docs/performance.md, "Geometric matcher").
        static const auto buffers = std::make_shared<ViewBufferPool>();
        GeometricPairResult r;
        {
          py::gil_scoped_release release;
          r = GeometricMatcher(o, buffers).run_with_points(input);
        }
        std::vector<Eigen::Vector3d> world;
        py::array_t<double> margin(static_cast<py::ssize_t>(r.points.size()));
        for (std::size_t k = 0; k < r.points.size(); ++k) {
          world.push_back(r.points[k].world);
          margin.mutable_at(static_cast<py::ssize_t>(k)) = r.points[k].margin;
        }
        py::dict d = result_dict(std::move(r));
        d["world_mm"] = rows_to_numpy<3>(world);
        d["margin"] = margin;
        return d;
      },
      py::arg("image_a"), py::arg("image_b"), py::arg("camera_a"), py::arg("camera_b"),
      py::kw_only(), py::arg("mask_a") = py::none(), py::arg("mask_b") = py::none(),
      py::arg("tolerance_px") = 3.0, py::arg("exact_vesselness") = false,
      py::arg("min_confidence") = py::none(), py::arg("field_a") = py::none(),
      py::arg("field_b") = py::none(), py::arg("detect_fields") = py::none(),
      py::arg("keep_catheter") = false, R"doc(
The training-free geometric matcher (docs/geometric-matcher.md), as gimm-match --method geometric
does for one pair: vessels segmented from the images (or the masks given), 2D centerlines, and a
dynamic programme along each centerline over the crossings of its epipolar lines, both ways.

image_a, image_b: float (rows, cols) in [0, 1], dark vessels on a bright background. camera_a,
camera_b: Camera or CArm, each for its image's size (required: the matcher is geometry).
mask_a, mask_b: optional vessel masks (nonzero = vessel), both or neither; without them the
images are segmented. tolerance_px: the epipolar tolerance (calibration error of real C-arms).
exact_vesselness: the slow reference kernels instead of the fast ones. min_confidence: the
DP margin a match needs at 4/3 pixels per mm at the isocentre, scaled with the images' pixels
per mm (default None: 0.5 with masks, 1 segmenting; gimm-match --min-confidence).
field_a, field_b: the exposed fields (nonzero = exposed, each its image's size); vessels outside
are not matched. Not given: found in the images when detect_fields (the collimator's dark frame,
match/field_of_view.hpp), else the whole image; detect_fields None (default): found when the
images are segmented (as gimm-match does for one pair), not with masks (as gimm-match --dataset).
keep_catheter: keep the segmented chains that look like the catheter (long and straight,
match/catheter_cue.hpp), which are dropped by default (gimm-match --keep-catheter).
Returns the result every matcher returns (Matcher.match too): dict(points_a, points_b (N, 2)
pixels (u, v), confidence (N,) (the ranking: the margin times how well the match is placed),
F (3, 3) from the cameras, F_source 'cameras', candidates, dropped_* (0), seconds), and margin
(N,) (the DP margin, what min_confidence thresholds), world_mm (N, 3) the triangulated points in
patient mm. The GIL is released while matching. The working memory of segmentation and
centerlines is kept between calls (about 25 MB at 512 px), so matching pair after pair does not
allocate it again.)doc");
}

}  // namespace gimm::python
