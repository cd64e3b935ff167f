#pragma once
/// Camera <-> JSON (nlohmann_json).
///
/// Schema (all lengths mm, angles degrees, pixel centres at integers):
/// {
///   "model": "perspective" | "orthographic",
///   "image_size": {"rows": 512, "cols": 512},
///   "K": [[..3], [..3], [..3]], "R": [[..3] x3], "t": [..3],
///   "P": [[..4] x3],                 // derived, written for convenience, checked on read
///   "center": [..3],                 // source (perspective) / virtual source point (ortho)
///   "principal_axis": [..3],         // unit vector source -> detector
///   // C-arm inputs, present when the camera came from a CArm:
///   "primary_deg", "secondary_deg", "sid_mm", "sod_mm", "pixel_mm", "isocenter": [..3],
///   and when used: "pixel_row_mm"; "table_mm", "reference_table_mm" ([lateral, vertical,
///   longitudinal]), "patient_position", "view_isocenter" (isocenter moved by the table)
/// }
/// Reading checks every field and names the bad one; K, R, t define the camera and "P",
/// when present, must agree with them.
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "gimm/core/error.hpp"
#include "gimm/geometry/camera.hpp"
#include "gimm/geometry/carm.hpp"
#include "gimm/io/files.hpp"

namespace gimm {

/// A matrix as JSON rows of numbers, a column vector as one flat array.
template <class Derived>
nlohmann::json matrix_to_json(const Eigen::MatrixBase<Derived>& m) {
  if (m.cols() == 1) {
    nlohmann::json v = nlohmann::json::array();
    for (Eigen::Index i = 0; i < m.rows(); ++i) v.push_back(m(i, 0));
    return v;
  }
  nlohmann::json rows = nlohmann::json::array();
  for (Eigen::Index r = 0; r < m.rows(); ++r) {
    nlohmann::json row = nlohmann::json::array();
    for (Eigen::Index c = 0; c < m.cols(); ++c) row.push_back(m(r, c));
    rows.push_back(row);
  }
  return rows;
}

/// Reads a fixed-size matrix (or vector, as a flat array) from j[key]; names key on error.
template <int R, int C>
Eigen::Matrix<double, R, C> matrix_from_json(const nlohmann::json& j, const char* key,
                                             const std::string& where) {
  GIMM_CHECK(j.contains(key), where << ": missing field '" << key << "'");
  const auto& v = j.at(key);
  Eigen::Matrix<double, R, C> m;
  auto number = [&](const nlohmann::json& x) {
    GIMM_CHECK(x.is_number(), where << ": field '" << key << "' has a non-number " << x.dump());
    const double d = x.get<double>();
    GIMM_CHECK(std::isfinite(d), where << ": field '" << key << "' has a non-finite entry");
    return d;
  };
  if (C == 1) {
    GIMM_CHECK(v.is_array() && v.size() == R, where << ": field '" << key
                                                    << "' must be an array of " << R
                                                    << " numbers, got " << v.dump());
    for (int r = 0; r < R; ++r) m(r, 0) = number(v[r]);
    return m;
  }
  GIMM_CHECK(v.is_array() && v.size() == R,
             where << ": field '" << key << "' must have " << R << " rows, got " << v.dump());
  for (int r = 0; r < R; ++r) {
    GIMM_CHECK(v[r].is_array() && v[r].size() == C, where << ": field '" << key << "' row " << r
                                                          << " must have " << C << " numbers, got "
                                                          << v[r].dump());
    for (int c = 0; c < C; ++c) m(r, c) = number(v[r][c]);
  }
  return m;
}

inline nlohmann::json to_json(const Camerad& camera) {
  nlohmann::json j;
  j["model"] = to_string(camera.model());
  j["image_size"] = {{"rows", camera.rows()}, {"cols", camera.cols()}};
  j["K"] = matrix_to_json(camera.K());
  j["R"] = matrix_to_json(camera.R());
  j["t"] = matrix_to_json(camera.t());
  j["P"] = matrix_to_json(camera.P());
  j["center"] = matrix_to_json(camera.center());
  j["principal_axis"] = matrix_to_json(camera.principal_axis());
  return j;
}

/// The camera of a C-arm pose, with the C-arm inputs recorded beside it.
inline nlohmann::json to_json(const CArm& carm) {
  nlohmann::json j = to_json(carm.camera());
  j["primary_deg"] = carm.primary_deg;
  j["secondary_deg"] = carm.secondary_deg;
  j["sid_mm"] = carm.sid_mm;
  j["sod_mm"] = carm.sod_mm;
  j["pixel_mm"] = carm.pixel_mm;
  j["isocenter"] = matrix_to_json(carm.isocenter);
  // The table and non-square pixels only when used, so plain C-arm cameras read as before.
  if (carm.pixel_row_mm > 0) j["pixel_row_mm"] = carm.pixel_row_mm;
  if (!carm.table_mm.isZero() || !carm.reference_table_mm.isZero()) {
    j["table_mm"] = matrix_to_json(carm.table_mm);
    j["reference_table_mm"] = matrix_to_json(carm.reference_table_mm);
    j["patient_position"] = to_string(carm.patient_position);
    j["view_isocenter"] = matrix_to_json(carm.view_isocenter());
  }
  j["principal_point"] = matrix_to_json(carm.principal_point_or_centre());
  return j;
}

/// Parses a camera; `where` names the source (a file name) in error messages.
inline Camerad camera_from_json(const nlohmann::json& j, const std::string& where = "camera") {
  GIMM_CHECK(j.is_object(), where << ": a camera must be a JSON object");
  GIMM_CHECK(j.contains("model") && j["model"].is_string(),
             where << ": missing string field 'model'");
  const std::string model_name = j["model"].get<std::string>();
  GIMM_CHECK(model_name == "perspective" || model_name == "orthographic",
             where << ": 'model' must be perspective or orthographic, got '" << model_name << "'");
  GIMM_CHECK(j.contains("image_size") && j["image_size"].is_object() &&
                 j["image_size"].contains("rows") && j["image_size"].contains("cols") &&
                 j["image_size"]["rows"].is_number_integer() &&
                 j["image_size"]["cols"].is_number_integer(),
             where << ": 'image_size' must be {\"rows\": int, \"cols\": int}");
  // Read wide and range-checked: get<int> would wrap 4294967360 to 64. The camera checks the
  // size itself once it is an int.
  const auto side = [&](const char* key) {
    const nlohmann::json& v = j["image_size"][key];
    GIMM_CHECK(json_int_in(v, std::numeric_limits<int>::min(), std::numeric_limits<int>::max()),
               where << ": 'image_size' " << key << " is out of range: " << v.dump());
    return v.get<int>();
  };
  const int rows = side("rows");
  const int cols = side("cols");
  const auto model =
      model_name == "perspective" ? ProjectionModel::perspective : ProjectionModel::orthographic;
  Camerad camera;
  try {
    camera =
        Camerad(model, matrix_from_json<3, 3>(j, "K", where), matrix_from_json<3, 3>(j, "R", where),
                matrix_from_json<3, 1>(j, "t", where), rows, cols);
  } catch (const Error& e) {
    throw Error(std::string(e.what()) + " (in " + where + ")");
  }
  if (j.contains("P")) {
    const Eigen::Matrix<double, 3, 4> P = matrix_from_json<3, 4>(j, "P", where);
    const double err = (P - camera.P()).cwiseAbs().maxCoeff();
    GIMM_CHECK(err <= 1e-6 * (1.0 + camera.P().cwiseAbs().maxCoeff()),
               where << ": 'P' disagrees with K [R | t] (max difference " << err << ")");
  }
  return camera;
}

/// How a view's 16-bit PNG maps back to intensity (camera.json "intensity_window": the
/// dataset's views and gimm-drr's).
/// `lo`, `hi`: the window's ends (render/drr.hpp's IntensityWindow).
inline nlohmann::json intensity_window_json(double lo, double hi) {
  return {{"min", lo},
          {"max", hi},
          {"png", "intensity = min + (max - min) * value / 65535"},
          {"intensity", "Beer-Lambert exp(-line integral), I0 = 1"}};
}

}  // namespace gimm
