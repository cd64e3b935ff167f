// gimm.fundamental_* and the epipolar distances, gating (gate_with_fundamental, gate_reference)
// and triangulation: the bindings of geometry/epipolar.hpp, fundamental.hpp, gating.hpp and
// triangulation.hpp.
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <cmath>
#include <limits>
#include <string>

#include "common.hpp"
#include "gimm/geometry/carm.hpp"
#include "gimm/geometry/epipolar.hpp"
#include "gimm/geometry/fundamental.hpp"
#include "gimm/geometry/gating.hpp"
#include "gimm/geometry/triangulation.hpp"

namespace gimm::python {

namespace {

py::object optional_matrix(const std::optional<Eigen::Matrix3d>& F) {
  return F ? py::object(to_numpy(*F)) : py::object(py::none());
}

GateOptions gate_options(const std::string& mode, double tau, double delta_px, int top_k,
                         int min_matches) {
  GateOptions o;
  o.mode = parse_gate_mode(mode);
  o.tau = tau;
  o.delta_px = delta_px;
  o.top_k = top_k;
  o.min_matches = min_matches;
  return o;
}

py::dict gate_dict(const GateResult<double>& g) {
  py::dict d;
  d["confidence"] = to_numpy(g.confidence);
  py::array_t<bool> keep(static_cast<py::ssize_t>(g.keep.size()));
  for (std::size_t i = 0; i < g.keep.size(); ++i) keep.mutable_data()[i] = g.keep[i] != 0;
  d["keep"] = keep;
  d["distance_sq"] =
      g.distance_sq.size() ? py::object(to_numpy(g.distance_sq)) : py::object(py::none());
  d["F"] = optional_matrix(g.F);
  return d;
}

/// (N,) of f(F, a_i, b_i) over the rows of two (N, 2) point arrays.
template <class Distance>
py::array_t<double> per_match(const py::handle& F_obj, const py::handle& a_obj,
                              const py::handle& b_obj, Distance&& f) {
  const Eigen::Matrix3d F = fixed<3, 3>(F_obj, "F");
  const auto a = points2(a_obj, "points_a"), b = points2(b_obj, "points_b");
  if (a.cols() != b.cols())
    throw py::value_error("points_a has " + std::to_string(a.cols()) + " points but points_b " +
                          std::to_string(b.cols()));
  py::array_t<double> out(a.cols());
  for (Eigen::Index i = 0; i < a.cols(); ++i)
    out.mutable_data()[i] = f(F, Eigen::Vector2d(a.col(i)), Eigen::Vector2d(b.col(i)));
  return out;
}

}  // namespace

void bind_epipolar(py::module_& m) {
  // ---- epipolar geometry and fundamental matrices -----------------------------------------
  m.def(
      "fundamental_from_cameras",
      [](const py::handle& a, const py::handle& b) {
        return to_numpy(
            fundamental_from_cameras(camera_of(a, "camera_a"), camera_of(b, "camera_b")));
      },
      py::arg("camera_a"), py::arg("camera_b"),
      "The exact F (3, 3) of two cameras (or CArms): x_b^T F x_a = 0 for pixels x_a of A and x_b "
      "of B, normalised to unit Frobenius norm with its largest entry positive. Raises "
      "gimm.Error when the two centres coincide.");
  m.def(
      "fundamental_8pt",
      [](const py::handle& a, const py::handle& b, const py::object& weights) {
        const Eigen::VectorXd w =
            weights.is_none() ? Eigen::VectorXd() : vector_of(weights, "weights");
        return optional_matrix(
            fundamental_8pt<double>(points2(a, "points_a"), points2(b, "points_b"), w));
      },
      py::arg("points_a"), py::arg("points_b"), py::arg("weights") = py::none(),
      "The paper's weighted normalised 8-point F (3, 3), x_b^T F x_a = 0, from points_a and "
      "points_b (N, 2) pixels (N >= 8) with optional weights (N,) >= 0. None for a degenerate "
      "configuration; gimm.Error for invalid input.");
  m.def(
      "fundamental_affine",
      [](const py::handle& a, const py::handle& b, const py::object& weights) {
        const Eigen::VectorXd w =
            weights.is_none() ? Eigen::VectorXd() : vector_of(weights, "weights");
        return optional_matrix(
            fundamental_affine<double>(points2(a, "points_a"), points2(b, "points_b"), w));
      },
      py::arg("points_a"), py::arg("points_b"), py::arg("weights") = py::none(),
      "The affine F of two orthographic views (Gold Standard, weighted), from (N, 2) pixel "
      "points (N >= 4); None for a degenerate configuration.");
  m.def(
      "estimate_fundamental_ransac",
      [](const py::handle& a, const py::handle& b, const std::string& model,
         const std::string& distance, double threshold_px, double confidence,
         std::int64_t max_iterations, std::int64_t min_iterations, int local_optimization_steps,
         std::uint64_t seed) {
        RansacOptions o;
        if (model != "perspective" && model != "affine")
          throw py::value_error("model must be 'perspective' or 'affine', got '" + model + "'");
        if (distance != "sampson" && distance != "symmetric")
          throw py::value_error("distance must be 'sampson' or 'symmetric', got '" + distance +
                                "'");
        o.model = model == "affine" ? FundamentalModel::affine : FundamentalModel::perspective;
        o.distance =
            distance == "symmetric" ? EpipolarDistance::symmetric : EpipolarDistance::sampson;
        o.threshold_px = threshold_px;
        o.confidence = confidence;
        o.max_iterations = max_iterations;
        o.min_iterations = min_iterations;
        o.local_optimization_steps = local_optimization_steps;
        o.seed = seed;
        const auto xa = points2(a, "points_a"), xb = points2(b, "points_b");
        RansacResult<double> r;
        {
          py::gil_scoped_release release;
          r = estimate_fundamental_ransac<double>(xa, xb, o);
        }
        py::dict d;
        d["F"] = optional_matrix(r.F);
        py::array_t<bool> inliers(static_cast<py::ssize_t>(r.inliers.size()));
        for (std::size_t i = 0; i < r.inliers.size(); ++i)
          inliers.mutable_data()[i] = r.inliers[i] != 0;
        d["inliers"] = inliers;
        d["iterations"] = r.stats.iterations;
        d["degenerate_samples"] = r.stats.degenerate_samples;
        d["local_optimizations"] = r.stats.local_optimizations;
        d["num_inliers"] = r.stats.num_inliers;
        d["inlier_ratio"] = r.stats.inlier_ratio;
        d["score"] = r.stats.score;
        return d;
      },
      py::arg("points_a"), py::arg("points_b"), py::kw_only(), py::arg("model") = "perspective",
      py::arg("distance") = "sampson", py::arg("threshold_px") = 1.0, py::arg("confidence") = 0.999,
      py::arg("max_iterations") = 10000, py::arg("min_iterations") = 10,
      py::arg("local_optimization_steps") = 3, py::arg("seed") = 0,
      "Robust F by MSAC with local optimisation from (N, 2) pixel points; model 'perspective' "
      "(8-point) or 'affine'; inliers by the 'sampson' or 'symmetric' distance <= threshold_px. "
      "Returns dict(F (3, 3) or None, inliers (N,) bool, iterations, degenerate_samples, "
      "local_optimizations, num_inliers, inlier_ratio, score (px^2)). Deterministic per seed.");
  m.def(
      "symmetric_epipolar_distance_sq",
      [](const py::handle& F, const py::handle& a, const py::handle& b) {
        return per_match(
            F, a, b,
            [](const Eigen::Matrix3d& f, const Eigen::Vector2d& x, const Eigen::Vector2d& y) {
              return symmetric_epipolar_distance_sq<double>(f, x, y);
            });
      },
      py::arg("F"), py::arg("points_a"), py::arg("points_b"),
      "(N,) squared symmetric epipolar distance, px^2: the squared distance of x_b to F x_a plus "
      "that of x_a to F^T x_b (what the gates use).");
  m.def(
      "sampson_distance_sq",
      [](const py::handle& F, const py::handle& a, const py::handle& b) {
        return per_match(
            F, a, b,
            [](const Eigen::Matrix3d& f, const Eigen::Vector2d& x, const Eigen::Vector2d& y) {
              return sampson_distance_sq<double>(f, x, y);
            });
      },
      py::arg("F"), py::arg("points_a"), py::arg("points_b"),
      "(N,) squared Sampson distance, px^2.");
  m.def(
      "epipolar_lines_b",
      [](const py::handle& F_obj, const py::handle& a_obj) {
        const Eigen::Matrix3d F = fixed<3, 3>(F_obj, "F");
        const auto a = rows_of(a_obj, 2, "points_a");
        Eigen::MatrixXd lines(a.rows(), 3);
        for (Eigen::Index i = 0; i < a.rows(); ++i)
          lines.row(i) = epipolar_line_b<double>(F, a.row(i).transpose()).transpose();
        return to_numpy(lines);
      },
      py::arg("F"), py::arg("points_a"),
      "(N, 3) epipolar lines in B of points_a (N, 2): l = F x_a, l[0] u + l[1] v + l[2] = 0.");

  // ---- gating ------------------------------------------------------------------------------
  const char* gate_doc =
      " Gates: 'hard' keeps matches with symmetric distance <= delta_px (others get confidence "
      "0, keep False); 'soft' c exp(-d^2 / tau^2); 'logit' c sigmoid(-d^2 / tau^2); 'none'. "
      "Returns dict(confidence (N,), keep (N,) bool, distance_sq (N,) px^2 or None, F (3, 3) or "
      "None).";
  m.def(
      "gate_with_fundamental",
      [](const py::handle& F, const py::handle& a, const py::handle& b,
         const py::handle& confidence, const std::string& mode, double tau, double delta_px) {
        return gate_dict(gate_with_fundamental<double>(
            fixed<3, 3>(F, "F"), points2(a, "points_a"), points2(b, "points_b"),
            vector_of(confidence, "confidence"), gate_options(mode, tau, delta_px, 256, 32)));
      },
      py::arg("F"), py::arg("points_a"), py::arg("points_b"), py::arg("confidence"), py::kw_only(),
      py::arg("mode") = "hard", py::arg("tau") = 2.0, py::arg("delta_px") = 2.0,
      (std::string("Gates match confidences (N,) with a given F (x_b^T F x_a = 0); points (N, 2) "
                   "pixels.") +
       gate_doc)
          .c_str());
  m.def(
      "fundamental_from_matches",
      [](const py::handle& a, const py::handle& b, const py::handle& confidence, int top_k,
         int min_matches) {
        return optional_matrix(fundamental_from_matches<double>(
            points2(a, "points_a"), points2(b, "points_b"), vector_of(confidence, "confidence"),
            gate_options("hard", 2.0, 2.0, top_k, min_matches)));
      },
      py::arg("points_a"), py::arg("points_b"), py::arg("confidence"), py::kw_only(),
      py::arg("top_k") = 256, py::arg("min_matches") = 32,
      "F estimated from matches as the reference does: the weighted 8-point (weights = "
      "confidence) on the top_k most confident matches; None with fewer than min_matches "
      "matches or a degenerate estimate.");
  m.def(
      "gate_reference",
      [](const py::handle& a, const py::handle& b, const py::handle& confidence,
         const std::string& mode, double tau, double delta_px, int top_k, int min_matches) {
        return gate_dict(gate_reference<double>(
            points2(a, "points_a"), points2(b, "points_b"), vector_of(confidence, "confidence"),
            gate_options(mode, tau, delta_px, top_k, min_matches)));
      },
      py::arg("points_a"), py::arg("points_b"), py::arg("confidence"), py::kw_only(),
      py::arg("mode") = "hard", py::arg("tau") = 2.0, py::arg("delta_px") = 2.0,
      py::arg("top_k") = 256, py::arg("min_matches") = 32,
      (std::string("The reference's gating: F from the matches (fundamental_from_matches), then "
                   "the gate; unchanged when there is no F.") +
       gate_doc)
          .c_str());

  // ---- triangulation -----------------------------------------------------------------------
  m.def(
      "triangulate",
      [](const py::sequence& cameras, const py::handle& pixels,
         const std::string& method) -> py::object {
        if (method != "dlt" && method != "midpoint")
          throw py::value_error("method must be 'dlt' or 'midpoint', got '" + method + "'");
        std::vector<Camerad> cams;
        for (std::size_t v = 0; v < cameras.size(); ++v)
          cams.push_back(camera_of(cameras[v], "cameras[" + std::to_string(v) + "]"));
        const auto a = as_doubles(pixels, "pixels");
        const bool single = a.ndim() == 2;
        if (!(single && a.shape(1) == 2) && !(a.ndim() == 3 && a.shape(2) == 2))
          throw py::value_error("pixels: expected shape (V, 2) or (V, N, 2), got " + shape_of(a));
        if (static_cast<std::size_t>(a.shape(0)) != cams.size())
          throw py::value_error("pixels: " + std::to_string(a.shape(0)) + " views for " +
                                std::to_string(cams.size()) + " cameras");
        const py::ssize_t views = a.shape(0), n = single ? 1 : a.shape(1);
        py::array_t<double> out({n, py::ssize_t{3}});
        auto w = out.mutable_unchecked<2>();
        bool found_single = false;
        for (py::ssize_t p = 0; p < n; ++p) {
          std::vector<Eigen::Vector2d> px;
          for (py::ssize_t v = 0; v < views; ++v) {
            const double* q = a.data() + (v * n + p) * 2;
            px.emplace_back(q[0], q[1]);
          }
          const auto X = method == "dlt" ? triangulate_dlt<double>(cams, px)
                                         : triangulate_midpoint<double>(cams, px);
          for (int d = 0; d < 3; ++d)
            w(p, d) = X ? (*X)[d] : std::numeric_limits<double>::quiet_NaN();
          found_single = X.has_value();
        }
        if (single) return found_single ? py::object(out[py::int_(0)]) : py::object(py::none());
        return out;
      },
      py::arg("cameras"), py::arg("pixels"), py::arg("method") = "dlt", R"doc(
Triangulates world points (mm) from their pixels in two or more views.
cameras: sequence of V Camera (or CArm); pixels: (V, 2) for one point -> (3,) or None when
degenerate (parallel rays), or (V, N, 2) for N points -> (N, 3) with NaN rows where degenerate.
method 'dlt' (linear, Hartley & Zisserman 12.2) or 'midpoint' (closest to all rays).)doc");
}

}  // namespace gimm::python
