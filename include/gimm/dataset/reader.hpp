#pragma once
/// The one reader of a gimm dataset (layout.hpp): patients and pairs by split, pair labels,
/// masks, cameras. Every caller (evaluation, baselines, matching, the reference export) reads
/// through it, so there is one rule for each field: dense label columns are found by name in
/// the pair's `dense_fields`, and the manifest's format must be kDatasetFormat (or /1).
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/core/image.hpp"
#include "gimm/dataset/layout.hpp"
#include "gimm/io/camera_json.hpp"
#include "gimm/io/files.hpp"
#include "gimm/io/png.hpp"
#include "gimm/labels/correspondence.hpp"
#include "gimm/labels/views.hpp"

namespace gimm {

/// The ground truth of one view pair: the dense labels, the exact F, both vessel masks, the
/// view names and classes.
struct PairTruth {
  std::string id;  ///< "<patient>/<pair>"
  std::string view_a, view_b;
  int view_class_a = kUnknownViewClass, view_class_b = kUnknownViewClass;
  Eigen::Matrix3d F = Eigen::Matrix3d::Zero();                ///< x_b^T F x_a = 0, pixels
  std::vector<Correspondence> dense;                          ///< GT labels: a, b (px), world (mm)
  std::shared_ptr<const Image<std::uint8_t>> mask_a, mask_b;  ///< nonzero = vessel

  /// The coronary system of the pair's view classes ("RCA", "LCA"; "" when the classes are
  /// unknown).
  std::string system() const {
    return view_class_a == kUnknownViewClass ? std::string()
                                             : to_string(view_class(view_class_a).system);
  }
};

namespace detail {
/// Column of `name` in `fields` (a pair's dense_fields), or -1 when absent.
inline int dense_column(const nlohmann::json& fields, const char* name) {
  for (std::size_t k = 0; k < fields.size(); ++k)
    if (fields[k].is_string() && fields[k].get<std::string>() == name) return static_cast<int>(k);
  return -1;
}
}  // namespace detail

/// The dense labels of a pair file, columns by name in its `dense_fields`: u_a v_a u_b v_b
/// (pixels) and x_mm y_mm z_mm are required, branch, point and radius_mm optional. Every row
/// holds one number per field; the required ones must be finite.
inline std::vector<Correspondence> dense_labels_from_json(const nlohmann::json& j,
                                                          const std::string& where) {
  GIMM_CHECK_AS(FormatError, j.is_object() && j.contains("dense_fields") && j.contains("dense"),
                where << ": a pair file needs 'dense_fields' and 'dense'");
  const nlohmann::json& fields = j.at("dense_fields");
  const nlohmann::json& dense = j.at("dense");
  GIMM_CHECK_AS(FormatError, fields.is_array(),
                where << ": 'dense_fields' must be an array, got " << fields.dump());
  GIMM_CHECK_AS(FormatError, dense.is_array(),
                where << ": 'dense' must be an array, got " << dense.type_name());
  static const char* const required[7] = {"u_a", "v_a", "u_b", "v_b", "x_mm", "y_mm", "z_mm"};
  int col[7];
  for (int k = 0; k < 7; ++k) {
    col[k] = detail::dense_column(fields, required[k]);
    GIMM_CHECK_AS(
        FormatError, col[k] >= 0,
        where << ": 'dense_fields' has no '" << required[k] << "', got " << fields.dump());
  }
  const int branch = detail::dense_column(fields, "branch");
  const int point = detail::dense_column(fields, "point");
  const int radius = detail::dense_column(fields, "radius_mm");
  std::vector<Correspondence> out;
  out.reserve(dense.size());
  for (std::size_t r = 0; r < dense.size(); ++r) {
    const nlohmann::json& row = dense[r];
    GIMM_CHECK_AS(FormatError, row.is_array() && row.size() == fields.size(),
                  where << ": dense row " << r << " must hold " << fields.size() << " numbers, got "
                        << row.dump());
    double v[7];
    for (int k = 0; k < 7; ++k) {
      const nlohmann::json& x = row[static_cast<std::size_t>(col[k])];
      GIMM_CHECK_AS(FormatError, x.is_number() && std::isfinite(x.get<double>()),
                    where << ": dense row " << r << ", '" << required[k]
                          << "' must be a finite number, got " << x.dump());
      v[k] = x.get<double>();
    }
    Correspondence c;
    c.a = {v[0], v[1]};
    c.b = {v[2], v[3]};
    c.world = {v[4], v[5], v[6]};
    const auto integer = [&](int column, const char* name) {
      const nlohmann::json& x = row[static_cast<std::size_t>(column)];
      GIMM_CHECK_AS(
          FormatError,
          json_int_in(x, std::numeric_limits<int>::min(), std::numeric_limits<int>::max()),
          where << ": dense row " << r << ", '" << name
                << "' must be an integer in int's range, got " << x.dump());
      return x.get<int>();
    };
    if (branch >= 0) c.branch = integer(branch, "branch");
    if (point >= 0) c.index = integer(point, "point");
    if (radius >= 0) {
      const nlohmann::json& x = row[static_cast<std::size_t>(radius)];
      GIMM_CHECK_AS(
          FormatError, x.is_number(),
          where << ": dense row " << r << ", 'radius_mm' must be a number, got " << x.dump());
      c.radius = x.get<double>();
    }
    out.push_back(c);
  }
  return out;
}

/// Parses a pair file (pairs/<pair>.json) without masks.
inline PairTruth pair_truth_from_json(const nlohmann::json& j, const std::string& id,
                                      const std::string& where) {
  PairTruth t;
  t.id = id;
  try {
    t.view_a = j.at("view_a").get<std::string>();
    t.view_b = j.at("view_b").get<std::string>();
    check_plain_name("view_a", t.view_a, where);  // "../../../x" reached outside views/
    check_plain_name("view_b", t.view_b, where);
    // An id out of range, or a number that is not an integer (49e9), is refused: converting it
    // to int would be undefined (found by libFuzzer).
    const auto view_class_of = [&](const char* key) {
      if (!j.contains(key)) return kUnknownViewClass;
      const nlohmann::json& v = j.at(key);
      GIMM_CHECK_AS(FormatError, json_int_in(v, kUnknownViewClass, kNumViewClassIds - 1),
                    where << ": '" << key << "' must be a view class id 1.." << kNumViewClassIds - 1
                          << " (0 = unknown), got " << v.dump());
      return v.get<int>();
    };
    t.view_class_a = view_class_of("view_class_a");
    t.view_class_b = view_class_of("view_class_b");
    t.F = matrix_from_json<3, 3>(j, "F", where);
    // All zeros passes as a matrix and turns every epipolar figure of the pair into null.
    GIMM_CHECK_AS(FormatError, t.F.cwiseAbs().maxCoeff() > 0,
                  where << ": 'F' is all zeros (no epipolar geometry)");
  } catch (const nlohmann::json::exception& e) {
    throw FormatError("gimm: " + where + ": " + e.what());
  }
  t.dense = dense_labels_from_json(j, where);
  return t;
}

/// Checks a manifest's format field (kDatasetFormat or kDatasetFormatV1); `where` names the file.
inline void check_dataset_format(const nlohmann::json& manifest, const std::string& where) {
  GIMM_CHECK_AS(
      FormatError, manifest.is_object() && manifest.contains("format"),
      where << ": no 'format' (a gimm dataset manifest says \"" << kDatasetFormat << "\")");
  const nlohmann::json& f = manifest.at("format");
  GIMM_CHECK_AS(FormatError,
                f.is_string() && (f.get<std::string>() == kDatasetFormat ||
                                  f.get<std::string>() == kDatasetFormatV1),
                where << ": format " << f.dump() << " is not " << kDatasetFormat << " (or "
                      << kDatasetFormatV1 << ")");
}

/// The images a dataset's views have: "drr" (<view>.png), and "formed" (<view>.formed.png)
/// and "field" (<view>.field.png) where a formation stage ran. /2 lists them; /1 says so in its
/// parameters (a "formation" record).
inline std::vector<std::string> dataset_images_of(const nlohmann::json& manifest,
                                                  const std::string& where) {
  const auto formed = std::vector<std::string>{"drr", "formed", "field"};
  if (manifest.value("format", "") == kDatasetFormatV1) {
    const auto& params =
        manifest.contains("parameters") ? manifest["parameters"] : nlohmann::json{};
    return params.is_object() && params.contains("formation") ? formed
                                                              : std::vector<std::string>{"drr"};
  }
  GIMM_CHECK_AS(FormatError, manifest.contains("images") && manifest["images"].is_array(),
                where << ": no 'images' list (a " << kDatasetFormat << " manifest has one)");
  std::vector<std::string> images;
  for (const auto& i : manifest["images"]) {
    GIMM_CHECK_AS(FormatError, i.is_string() && (i == "drr" || i == "formed" || i == "field"),
                  where << ": 'images' holds " << i.dump() << " (drr|formed|field)");
    images.push_back(i.get<std::string>());
  }
  return images;
}

/// What the writer lists under "images" for a run with or without a formation stage.
inline nlohmann::json dataset_images(bool formation) {
  return formation ? nlohmann::json{"drr", "formed", "field"} : nlohmann::json{"drr"};
}

/// Reads pairs, masks and cameras of a gimm-dataset directory; masks are cached per patient
/// (views are shared by many pairs).
class DatasetReader {
 public:
  explicit DatasetReader(std::filesystem::path root) : layout_(std::move(root)) {
    GIMM_CHECK_AS(IoError, std::filesystem::is_directory(layout_.patients_dir()),
                  "'" << root_string() << "' is not a gimm-dataset directory (no patients/)");
    const auto manifest = layout_.manifest();
    if (std::filesystem::exists(manifest)) {
      manifest_ = read_json_file(manifest);
      check_dataset_format(manifest_, manifest.string());
    }
  }

  const std::filesystem::path& root() const { return layout_.root(); }
  const DatasetLayout& layout() const { return layout_; }
  /// manifest.json (null when the dataset has none yet, e.g. shards not merged).
  const nlohmann::json& manifest() const { return manifest_; }
  /// The images every view has (dataset_images_of); {"drr"} without a manifest.
  std::vector<std::string> images() const {
    return manifest_.is_null() ? std::vector<std::string>{"drr"}
                               : dataset_images_of(manifest_, layout_.manifest().string());
  }
  bool has_formed_views() const {
    const auto i = images();
    return std::find(i.begin(), i.end(), "formed") != i.end();
  }

  /// The patients whose status is "ok" in manifest.json (all patient folders with done.json
  /// if there is no manifest), restricted to splits/<split>.txt unless split is "all"; sorted.
  std::vector<std::string> patients(const std::string& split = "all") const {
    namespace fs = std::filesystem;
    std::vector<std::string> patients;
    if (!manifest_.is_null()) {
      const std::string where = layout_.manifest().string();
      const auto* list = manifest_.contains("patients") ? &manifest_["patients"] : nullptr;
      GIMM_CHECK_AS(FormatError, list && list->is_array(),
                    where << ": 'patients' must be an array of patient records, got "
                          << (list ? list->dump() : std::string("nothing")));
      for (std::size_t k = 0; k < list->size(); ++k) {
        const nlohmann::json& p = (*list)[k];
        GIMM_CHECK_AS(FormatError,
                      p.is_object() && p.contains("id") && p["id"].is_string() &&
                          (!p.contains("status") || p["status"].is_string()),
                      where << ": 'patients'[" << k
                            << "] must be an object with a string 'id' and 'status', got "
                            << p.dump());
        if (p.value("status", "") != "ok") continue;
        const std::string id = p["id"].get<std::string>();
        check_patient_name(id, where + ": 'patients'[" + std::to_string(k) + "]");
        // A patient the manifest calls finished must be there: skipping it would score a
        // dataset with a hole in it as if it were whole.
        GIMM_CHECK_AS(FormatError, fs::is_directory(layout_.patient_dir(id)),
                      where << ": patient '" << id << "' is listed as ok but its folder "
                            << layout_.patient_dir(id).string() << " is missing");
        patients.push_back(id);
      }
    } else {
      for (const auto& e : fs::directory_iterator(layout_.patients_dir())) {
        const std::string name = e.path().filename().string();
        // A staging folder (patients/<id>.tmp.<host>.<pid>/) is a patient being made.
        if (!is_temporary_name(name) && fs::exists(e.path() / "done.json"))
          patients.push_back(name);
      }
    }
    if (split != "all") {
      const fs::path list = layout_.split_list(split);
      GIMM_CHECK_AS(IoError, fs::exists(list), "no split list '" << list.string() << "'");
      std::ifstream in(list);
      std::vector<std::string> keep;
      for (std::string line; std::getline(in, line);)
        if (!line.empty()) keep.push_back(line);
      patients.erase(std::remove_if(patients.begin(), patients.end(),
                                    [&](const std::string& p) {
                                      return std::find(keep.begin(), keep.end(), p) == keep.end();
                                    }),
                     patients.end());
    }
    std::sort(patients.begin(), patients.end());
    return patients;
  }

  /// The pair files' stems of one patient (temporaries of an interrupted run excluded), sorted.
  std::vector<std::string> pairs_of(const std::string& patient) const {
    namespace fs = std::filesystem;
    std::vector<std::string> stems;
    const fs::path dir = layout_.pairs_dir(patient);
    if (!fs::is_directory(dir)) return stems;
    for (const auto& e : fs::directory_iterator(dir))
      if (e.path().extension() == ".json" && !is_temporary_name(e.path().filename().string()))
        stems.push_back(e.path().stem().string());
    std::sort(stems.begin(), stems.end());
    return stems;
  }

  /// Pair ids ("<patient>/<pair>") of patients(split); sorted.
  std::vector<std::string> pair_ids(const std::string& split = "all") const {
    std::vector<std::string> ids;
    for (const auto& patient : patients(split))
      for (const auto& stem : pairs_of(patient)) ids.push_back(patient + "/" + stem);
    std::sort(ids.begin(), ids.end());
    return ids;
  }

  /// The pair file as stored (sparse labels and all), for callers that need more than truth.
  nlohmann::json pair_json(const std::string& id) const {
    return read_json_file(layout_.pair_labels(id));
  }

  /// The pair's labels, F and both masks.
  PairTruth pair(const std::string& id) {
    const auto [patient, stem] = split_pair_id(id);
    const auto file = layout_.pair_labels(patient, stem);
    PairTruth t = pair_truth_from_json(read_json_file(file), id, file.string());
    if (patient != cached_patient_) {
      masks_.clear();
      cached_patient_ = patient;
    }
    t.mask_a = mask(patient, t.view_a);
    t.mask_b = mask(patient, t.view_b);
    check_labels_inside(t.dense, *t.mask_a, true, layout_.view_mask(patient, t.view_a), file);
    check_labels_inside(t.dense, *t.mask_b, false, layout_.view_mask(patient, t.view_b), file);
    return t;
  }

  /// The camera of a view (views/<view>.camera.json).
  Camerad camera(const std::string& patient, const std::string& view) const {
    const auto file = layout_.view_camera(patient, view);
    return camera_from_json(read_json_file(file), file.string());
  }

 private:
  std::string root_string() const { return layout_.root().string(); }

  /// A mask of another size than its view (a 1 x 1 PNG) would score the labels against the
  /// wrong pixels: every label of the pair must lie on its view's mask image.
  static void check_labels_inside(const std::vector<Correspondence>& dense,
                                  const Image<std::uint8_t>& mask, bool side_a,
                                  const std::filesystem::path& mask_file,
                                  const std::filesystem::path& pair_file) {
    for (const Correspondence& c : dense) {
      const Eigen::Vector2d& p = side_a ? c.a : c.b;
      GIMM_CHECK_AS(
          FormatError,
          p.x() > -0.5 && p.y() > -0.5 && p.x() < mask.cols() - 0.5 && p.y() < mask.rows() - 0.5,
          "'" << mask_file.string() << "' is " << mask.cols() << " x " << mask.rows()
              << " px, but '" << pair_file.string() << "' labels (" << p.x() << ", " << p.y()
              << ") in that view");
    }
  }

  std::shared_ptr<const Image<std::uint8_t>> mask(const std::string& patient,
                                                  const std::string& view) {
    auto it = masks_.find(view);
    if (it != masks_.end()) return it->second;
    auto m =
        std::make_shared<const Image<std::uint8_t>>(read_png8(layout_.view_mask(patient, view)));
    masks_[view] = m;
    return m;
  }

  DatasetLayout layout_;
  nlohmann::json manifest_;
  std::string cached_patient_;
  std::map<std::string, std::shared_ptr<const Image<std::uint8_t>>> masks_;
};

}  // namespace gimm
