// gimm.CArm and gimm.Camera (epipolar geometry, fundamental matrices, gating and triangulation:
// epipolar.cpp, a file of its own so that a change to those headers recompiles only it).
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <cmath>
#include <limits>
#include <sstream>

#include "common.hpp"
#include "gimm/geometry/carm.hpp"

namespace gimm::python {

Camerad camera_of(const py::handle& obj, const std::string& name) {
  if (py::isinstance<Camerad>(obj)) return obj.cast<Camerad>();
  if (py::isinstance<CArm>(obj)) return obj.cast<const CArm&>().camera();
  throw py::type_error(name + ": expected a gimm.Camera or gimm.CArm, got " +
                       std::string(py::str(py::type::handle_of(obj).attr("__name__"))));
}

namespace {

PatientPosition parse_position(const std::string& name) {
  if (name == "HFS") return PatientPosition::HFS;
  if (name == "FFS") return PatientPosition::FFS;
  throw py::value_error("patient_position must be 'HFS' or 'FFS', got '" + name + "'");
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
          "(3,) the patient's move in patient mm caused by the table's move (it rides on the table)")
      .def(
          "view_isocenter", [](const CArm& c) { return to_numpy(c.view_isocenter()); },
          "(3,) this view's isocentre, world mm (isocenter - table_shift())")
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
}

}  // namespace gimm::python
