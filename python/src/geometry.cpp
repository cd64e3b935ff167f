// gimm.CArm, gimm.Camera, epipolar geometry, fundamental matrices, gating, triangulation.
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <cmath>
#include <limits>
#include <sstream>

#include "common.hpp"
#include "gimm/geometry/carm.hpp"
#include "gimm/geometry/epipolar.hpp"
#include "gimm/geometry/fundamental.hpp"
#include "gimm/geometry/gating.hpp"
#include "gimm/geometry/triangulation.hpp"

namespace gimm::python {

Camerad camera_of(const py::handle& obj, const std::string& name) {
  if (py::isinstance<Camerad>(obj)) return obj.cast<Camerad>();
  if (py::isinstance<CArm>(obj)) return obj.cast<const CArm&>().camera();
  throw py::type_error(name + ": expected a gimm.Camera or gimm.CArm, got " +
                       std::string(py::str(py::type::handle_of(obj).attr("__name__"))));
}

namespace {

py::object optional_matrix(const std::optional<Eigen::Matrix3d>& F) {
  return F ? py::object(to_numpy(*F)) : py::object(py::none());
}

PatientPosition parse_position(const std::string& name) {
  if (name == "HFS") return PatientPosition::HFS;
  if (name == "FFS") return PatientPosition::FFS;
  throw py::value_error("patient_position must be 'HFS' or 'FFS', got '" + name + "'");
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

std::string camera_repr(const Camerad& c) {
  std::ostringstream s;
  s << "gimm.Camera(" << to_string(c.model()) << ", " << c.cols() << "x" << c.rows()
    << " px, center=(" << c.center().transpose() << ") mm)";
  return s.str();
}

}  // namespace

void bind_geometry(py::module_& m) {
  // ---- Camera ------------------------------------------------------------------------------
  py::class_<Camerad>(m, "Camera", R"doc(
A camera mapping world millimetres (patient LPS) to detector pixels with P = K [R | t].

Camera axes are the rows of R: x_cam along increasing u (image right), y_cam up in the image
(decreasing v), z_cam from the source towards the detector, so K = [[f, 0, cu], [0, -f, cv],
[0, 0, 1]] has a negative second focal entry. Pixel (col j, row i) has its centre at
(u, v) = (j, i). Perspective: x ~ K (R X + t), the source is C = -R^T t and depth is mm along
z_cam from the source. Orthographic (parallel beam): P's last row is (0, 0, 0, 1), f = 1 / pixel
size in mm, depth is mm from the virtual source plane.
Usually made by CArm.camera(); pickles by value.)doc")
      .def(py::init([](const py::handle& K, const py::handle& R, const py::handle& t, int rows,
                       int cols, const std::string& model) {
             return Camerad(parse_model(model), fixed<3, 3>(K, "K"), fixed<3, 3>(R, "R"),
                            fixed<3, 1>(t, "t"), rows, cols);
           }),
           py::arg("K"), py::arg("R"), py::arg("t"), py::arg("rows"), py::arg("cols"),
           py::arg("model") = "perspective",
           "K (3, 3) upper triangular with K[2, 2] = 1; R (3, 3) a rotation; t (3,) mm; rows and "
           "cols in pixels; model 'perspective' or 'orthographic'. Raises gimm.Error on invalid "
           "values.")
      .def_property_readonly(
          "model", [](const Camerad& c) { return to_string(c.model()); },
          "'perspective' or 'orthographic'")
      .def_property_readonly(
          "K", [](const Camerad& c) { return to_numpy(c.K()); }, "(3, 3) intrinsics, pixels")
      .def_property_readonly(
          "R", [](const Camerad& c) { return to_numpy(c.R()); }, "(3, 3) world-to-camera rotation")
      .def_property_readonly(
          "t", [](const Camerad& c) { return to_numpy(c.t()); }, "(3,) translation, mm")
      .def_property_readonly(
          "P", [](const Camerad& c) { return to_numpy(c.P()); },
          "(3, 4) projection matrix: pixels ~ P (X, 1) for X in world mm")
      .def_property_readonly(
          "center", [](const Camerad& c) { return to_numpy(c.center()); },
          "(3,) world mm: the source (perspective), or the principal ray's point on the virtual "
          "source plane (orthographic)")
      .def_property_readonly(
          "principal_axis", [](const Camerad& c) { return to_numpy(c.principal_axis()); },
          "(3,) unit vector from the source towards the detector (z_cam)")
      .def_property_readonly("rows", &Camerad::rows, "detector rows (image height), pixels")
      .def_property_readonly("cols", &Camerad::cols, "detector columns (image width), pixels")
      .def_property_readonly(
          "shape", [](const Camerad& c) { return py::make_tuple(c.rows(), c.cols()); },
          "(rows, cols): the shape of this camera's images")
      .def(
          "project",
          [](const Camerad& c, const py::handle& points) {
            const auto a = as_doubles(points, "points");
            const bool single = a.ndim() == 1;
            const auto X =
                single ? Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>(
                             fixed<3, 1>(a, "points").transpose())
                       : rows_of(a, 3, "points");
            py::array_t<double> uv({static_cast<py::ssize_t>(X.rows()), py::ssize_t{2}});
            py::array_t<double> depth(X.rows());
            auto w = uv.mutable_unchecked<2>();
            for (Eigen::Index n = 0; n < X.rows(); ++n) {
              const auto p = c.project(X.row(n).transpose());
              w(n, 0) = p.uv.x();
              w(n, 1) = p.uv.y();
              depth.mutable_data()[n] = p.depth;
            }
            if (single) return py::make_tuple(uv[py::int_(0)], depth.data()[0]);
            return py::make_tuple(uv, depth);
          },
          py::arg("points"), R"doc(
Projects world points (mm, LPS): points (N, 3) -> (uv (N, 2) pixels as (u, v) = (column, row),
depth (N,) mm along the principal axis). A single point (3,) gives (uv (2,), depth float).
A point is in front of the source iff depth > 0; behind it (perspective) uv is still the
algebraic projection, so check depth.)doc")
      .def(
          "ray",
          [](const Camerad& c, double u, double v) {
            const auto r = c.ray(u, v);
            return py::make_tuple(to_numpy(r.origin), to_numpy(r.direction));
          },
          py::arg("u"), py::arg("v"),
          "The ray through pixel coordinates (u, v) = (column, row): (origin (3,) mm, direction "
          "(3,) unit). Perspective rays start at the source, orthographic ones on the virtual "
          "source plane; the direction points from the source towards the detector.")
      .def(
          "on_detector",
          [](const Camerad& c, const py::handle& uv) {
            const auto p = rows_of(uv, 2, "uv");
            py::array_t<bool> out(p.rows());
            for (Eigen::Index n = 0; n < p.rows(); ++n)
              out.mutable_data()[n] = c.on_detector(p.row(n).transpose());
            return out;
          },
          py::arg("uv"),
          "(N,) bool: uv (N, 2) lies on the detector [-0.5, cols - 0.5] x [-0.5, rows - 0.5].")
      .def("__repr__", &camera_repr)
      .def(py::pickle(
          [](const Camerad& c) {
            return py::make_tuple(to_numpy(c.K()), to_numpy(c.R()), to_numpy(c.t()), c.rows(),
                                  c.cols(), to_string(c.model()));
          },
          [](const py::tuple& s) {
            return Camerad(parse_model(s[5].cast<std::string>()), fixed<3, 3>(s[0], "K"),
                           fixed<3, 3>(s[1], "R"), fixed<3, 1>(s[2], "t"), s[3].cast<int>(),
                           s[4].cast<int>());
          }));

  // ---- CArm --------------------------------------------------------------------------------
  py::class_<CArm>(m, "CArm", R"doc(
A C-arm pose and detector (DICOM X-ray angiography conventions; docs/conventions.md).

primary_deg > 0 is LAO, < 0 RAO (rotation about the head-foot axis); secondary_deg > 0 is
cranial, < 0 caudal. At 0/0 (AP) the source is posterior and the detector anterior; the image
shows the patient's left on the image's right and the head at the top. SID (source-detector)
and SOD (source-isocentre) in mm. pixel_mm is the detector pitch across columns, pixel_row_mm
down the rows (0: square pixels). principal_point (u, v) in pixels, None: the detector centre
((cols - 1) / 2, (rows - 1) / 2). isocenter: world mm (LPS) at the reference table.
table_mm / reference_table_mm: (lateral, vertical, longitudinal) table positions of this view
and of the reference view, mm; the isocentre moves by their difference, mapped to patient
+x, +y, +z for a head-first supine patient ('HFS'; 'FFS' turns x and z round).
Vector fields read as numpy arrays and accept any sequence of numbers.)doc")
      .def(py::init([](double primary_deg, double secondary_deg, double sid_mm, double sod_mm,
                       int rows, int cols, double pixel_mm, double pixel_row_mm,
                       const py::object& principal_point, const py::object& isocenter,
                       const py::object& table_mm, const py::object& reference_table_mm,
                       const std::string& patient_position, const std::string& model) {
             CArm c;
             c.primary_deg = primary_deg;
             c.secondary_deg = secondary_deg;
             c.sid_mm = sid_mm;
             c.sod_mm = sod_mm;
             c.rows = rows;
             c.cols = cols;
             c.pixel_mm = pixel_mm;
             c.pixel_row_mm = pixel_row_mm;
             if (!principal_point.is_none())
               c.principal_point = fixed<2, 1>(principal_point, "principal_point");
             if (!isocenter.is_none()) c.isocenter = fixed<3, 1>(isocenter, "isocenter");
             if (!table_mm.is_none()) c.table_mm = fixed<3, 1>(table_mm, "table_mm");
             if (!reference_table_mm.is_none())
               c.reference_table_mm = fixed<3, 1>(reference_table_mm, "reference_table_mm");
             c.patient_position = parse_position(patient_position);
             c.model = parse_model(model);
             return c;
           }),
           py::kw_only(), py::arg("primary_deg") = 0.0, py::arg("secondary_deg") = 0.0,
           py::arg("sid_mm") = 1000.0, py::arg("sod_mm") = 750.0, py::arg("rows") = 512,
           py::arg("cols") = 512, py::arg("pixel_mm") = 0.5, py::arg("pixel_row_mm") = 0.0,
           py::arg("principal_point") = py::none(), py::arg("isocenter") = py::none(),
           py::arg("table_mm") = py::none(), py::arg("reference_table_mm") = py::none(),
           py::arg("patient_position") = "HFS", py::arg("model") = "perspective",
           "Keyword arguments only; defaults: AP, SID 1000 mm, SOD 750 mm, 512 x 512 pixels of "
           "0.5 mm, isocentre at the world origin, perspective. Values are checked by "
           "validate() and camera().")
      .def_readwrite("primary_deg", &CArm::primary_deg, "+LAO / -RAO, degrees")
      .def_readwrite("secondary_deg", &CArm::secondary_deg, "+cranial / -caudal, degrees")
      .def_readwrite("sid_mm", &CArm::sid_mm, "source to detector, mm")
      .def_readwrite("sod_mm", &CArm::sod_mm, "source to isocentre, mm")
      .def_readwrite("rows", &CArm::rows, "detector rows, pixels")
      .def_readwrite("cols", &CArm::cols, "detector columns, pixels")
      .def_readwrite("pixel_mm", &CArm::pixel_mm, "detector pitch across columns, mm")
      .def_readwrite("pixel_row_mm", &CArm::pixel_row_mm,
                     "detector pitch down the rows, mm; 0: square pixels (pixel_mm)")
      .def_property(
          "principal_point",
          [](const CArm& c) -> py::object {
            return c.principal_point ? py::object(to_numpy(*c.principal_point)) : py::none();
          },
          [](CArm& c, const py::object& v) {
            if (v.is_none())
              c.principal_point.reset();
            else
              c.principal_point = fixed<2, 1>(v, "principal_point");
          },
          "(u, v) pixels, or None for the detector centre")
      .def_property(
          "isocenter", [](const CArm& c) { return to_numpy(c.isocenter); },
          [](CArm& c, const py::handle& v) { c.isocenter = fixed<3, 1>(v, "isocenter"); },
          "(3,) world mm (LPS), at the reference table (a copy: assign a new value to change it)")
      .def_property(
          "table_mm", [](const CArm& c) { return to_numpy(c.table_mm); },
          [](CArm& c, const py::handle& v) { c.table_mm = fixed<3, 1>(v, "table_mm"); },
          "(3,) this view's table (lateral, vertical, longitudinal), mm")
      .def_property(
          "reference_table_mm", [](const CArm& c) { return to_numpy(c.reference_table_mm); },
          [](CArm& c, const py::handle& v) {
            c.reference_table_mm = fixed<3, 1>(v, "reference_table_mm");
          },
          "(3,) the reference view's table (lateral, vertical, longitudinal), mm")
      .def_property(
          "patient_position", [](const CArm& c) { return to_string(c.patient_position); },
          [](CArm& c, const std::string& v) { c.patient_position = parse_position(v); },
          "'HFS' (head-first supine) or 'FFS' (feet-first supine), for the table axes")
      .def_property(
          "model", [](const CArm& c) { return to_string(c.model); },
          [](CArm& c, const std::string& v) { c.model = parse_model(v); },
          "'perspective' (point source) or 'orthographic' (parallel beam, same field of view at "
          "the isocentre)")
      .def("camera", &CArm::camera, "The Camera of this pose (validates the fields first).")
      .def("validate", &CArm::validate, "Raises gimm.Error naming the first bad field.")
      .def(
          "rotation", [](const CArm& c) { return to_numpy(c.rotation()); },
          "(3, 3) world-to-camera rotation (rows: x_cam, y_cam, z_cam)")
      .def(
          "source_direction", [](const CArm& c) { return to_numpy(c.source_direction()); },
          "(3,) unit vector from the isocentre to the source")
      .def(
          "source_position", [](const CArm& c) { return to_numpy(c.source_position()); },
          "(3,) the source, world mm")
      .def(
          "table_shift", [](const CArm& c) { return to_numpy(c.table_shift()); },
          "(3,) the isocentre's move in patient mm caused by the table's move")
      .def(
          "view_isocenter", [](const CArm& c) { return to_numpy(c.view_isocenter()); },
          "(3,) this view's isocentre, world mm (isocenter + table_shift())")
      .def("row_pixel_mm", &CArm::row_pixel_mm, "pitch down the rows, mm")
      .def(
          "principal_point_or_centre",
          [](const CArm& c) { return to_numpy(c.principal_point_or_centre()); },
          "(u, v) the principal point, pixels")
      .def("__repr__",
           [](const CArm& c) {
             std::ostringstream s;
             s << "gimm.CArm(primary_deg=" << c.primary_deg << ", secondary_deg=" << c.secondary_deg
               << ", sid_mm=" << c.sid_mm << ", sod_mm=" << c.sod_mm << ", rows=" << c.rows
               << ", cols=" << c.cols << ", pixel_mm=" << c.pixel_mm << ", model='"
               << to_string(c.model) << "')";
             return s.str();
           })
      .def(py::pickle(
          [](const CArm& c) {
            py::object pp = c.principal_point ? py::object(to_numpy(*c.principal_point))
                                              : py::object(py::none());
            return py::make_tuple(c.primary_deg, c.secondary_deg, c.sid_mm, c.sod_mm, c.rows,
                                  c.cols, c.pixel_mm, c.pixel_row_mm, pp, to_numpy(c.isocenter),
                                  to_numpy(c.table_mm), to_numpy(c.reference_table_mm),
                                  to_string(c.patient_position), to_string(c.model));
          },
          [](const py::tuple& s) {
            CArm c;
            c.primary_deg = s[0].cast<double>();
            c.secondary_deg = s[1].cast<double>();
            c.sid_mm = s[2].cast<double>();
            c.sod_mm = s[3].cast<double>();
            c.rows = s[4].cast<int>();
            c.cols = s[5].cast<int>();
            c.pixel_mm = s[6].cast<double>();
            c.pixel_row_mm = s[7].cast<double>();
            if (!s[8].is_none()) c.principal_point = fixed<2, 1>(s[8], "principal_point");
            c.isocenter = fixed<3, 1>(s[9], "isocenter");
            c.table_mm = fixed<3, 1>(s[10], "table_mm");
            c.reference_table_mm = fixed<3, 1>(s[11], "reference_table_mm");
            c.patient_position = parse_position(s[12].cast<std::string>());
            c.model = parse_model(s[13].cast<std::string>());
            return c;
          }));

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
