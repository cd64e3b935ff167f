#pragma once
/// The ground truth of one view pair as the evaluation needs it, read from a `gimm-dataset`
/// directory (docs/dataset.md): the dense labels, the exact F, both vessel masks, the view
/// names and classes. Pair ids are "<patient>/<pair stem>", e.g. "phantom-0000/LCA_00-01".
#include <Eigen/Core>
#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/core/image.hpp"
#include "gimm/io/camera_json.hpp"
#include "gimm/io/files.hpp"
#include "gimm/io/png.hpp"
#include "gimm/labels/correspondence.hpp"
#include "gimm/labels/views.hpp"

namespace gimm {

struct PairTruth {
  std::string id;  ///< "<patient>/<pair stem>"
  std::string view_a, view_b;
  int view_class_a = kUnknownViewClass, view_class_b = kUnknownViewClass;
  Eigen::Matrix3d F = Eigen::Matrix3d::Zero();                ///< x_b^T F x_a = 0, pixels
  std::vector<Correspondence> dense;                          ///< GT labels: a, b (px), world (mm)
  std::shared_ptr<const Image<std::uint8_t>> mask_a, mask_b;  ///< nonzero = vessel

  /// The coronary system: the view name's prefix before '_' ("RCA_00" -> "RCA").
  std::string system() const { return view_a.substr(0, view_a.find('_')); }
};

/// Readable name of a view class ("LAO Cranial"), "unknown" for 0 or anything out of range.
inline std::string view_class_label(int id) {
  if (id < 1 || id > 11) return "unknown";
  return view_class(id).name;
}

/// The breakdown key of a pair's view classes, lower id first: "RCA AP Cranial / LAO".
inline std::string class_pair_key(const PairTruth& t) {
  int a = t.view_class_a, b = t.view_class_b;
  if (b < a) std::swap(a, b);
  return t.system() + " " + view_class_label(a) + " / " + view_class_label(b);
}

/// Parses a pair JSON (the dataset's pairs/<stem>.json) without masks.
inline PairTruth pair_truth_from_json(const nlohmann::json& j, const std::string& id,
                                      const std::string& where) {
  PairTruth t;
  t.id = id;
  try {
    t.view_a = j.at("view_a").get<std::string>();
    t.view_b = j.at("view_b").get<std::string>();
    t.view_class_a = j.value("view_class_a", kUnknownViewClass);
    t.view_class_b = j.value("view_class_b", kUnknownViewClass);
    t.F = detail::matrix_from_json<3, 3>(j, "F", where);
    for (const auto& row : j.at("dense")) {
      GIMM_CHECK_AS(FormatError, row.is_array() && row.size() >= 7,
                    where << ": a dense row needs at least u_a v_a u_b v_b x y z");
      Correspondence c;
      c.a = {row[0].get<double>(), row[1].get<double>()};
      c.b = {row[2].get<double>(), row[3].get<double>()};
      c.world = {row[4].get<double>(), row[5].get<double>(), row[6].get<double>()};
      if (row.size() >= 10) {
        c.branch = row[7].get<int>();
        c.index = row[8].get<int>();
        c.radius = row[9].get<double>();
      }
      t.dense.push_back(c);
    }
  } catch (const nlohmann::json::exception& e) {
    throw FormatError("gimm: " + where + ": " + e.what());
  }
  return t;
}

/// Reads pairs and masks of a gimm-dataset directory; masks are cached per patient (views are
/// shared by many pairs).
class DatasetReader {
 public:
  explicit DatasetReader(std::filesystem::path root) : root_(std::move(root)) {
    GIMM_CHECK_AS(IoError, std::filesystem::is_directory(root_ / "patients"),
                  "'" << root_.string() << "' is not a gimm-dataset directory (no patients/)");
  }

  const std::filesystem::path& root() const { return root_; }

  /// Pair ids of the patients whose status is "ok" in manifest.json (all patient folders with
  /// done.json if there is no manifest), restricted to splits/<split>.txt unless split is
  /// "all"; sorted.
  std::vector<std::string> pair_ids(const std::string& split = "all") const {
    namespace fs = std::filesystem;
    std::vector<std::string> patients;
    const fs::path manifest = root_ / "manifest.json";
    if (fs::exists(manifest)) {
      const nlohmann::json m = read_json_file(manifest);  // outlives the loop
      for (const auto& p : m.at("patients"))
        if (p.value("status", "") == "ok") patients.push_back(p.at("id").get<std::string>());
    } else {
      for (const auto& e : fs::directory_iterator(root_ / "patients"))
        if (fs::exists(e.path() / "done.json")) patients.push_back(e.path().filename().string());
    }
    if (split != "all") {
      const fs::path list = root_ / "splits" / (split + ".txt");
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
    std::vector<std::string> ids;
    for (const auto& patient : patients) {
      const fs::path dir = root_ / "patients" / patient / "pairs";
      if (!fs::is_directory(dir)) continue;
      for (const auto& e : fs::directory_iterator(dir))
        if (e.path().extension() == ".json" &&
            e.path().filename().string().find(".tmp.") == std::string::npos)
          ids.push_back(patient + "/" + e.path().stem().string());
    }
    std::sort(ids.begin(), ids.end());
    return ids;
  }

  /// The pair's labels, F and both masks.
  PairTruth pair(const std::string& id) {
    namespace fs = std::filesystem;
    const auto slash = id.find('/');
    GIMM_CHECK(slash != std::string::npos, "pair id must be <patient>/<pair>, got '" << id << "'");
    const std::string patient = id.substr(0, slash);
    const fs::path file = root_ / "patients" / patient / "pairs" / (id.substr(slash + 1) + ".json");
    PairTruth t = pair_truth_from_json(read_json_file(file), id, file.string());
    if (patient != cached_patient_) {
      masks_.clear();
      cached_patient_ = patient;
    }
    t.mask_a = mask(patient, t.view_a);
    t.mask_b = mask(patient, t.view_b);
    return t;
  }

  /// The camera of a view (views/<name>.camera.json).
  Camerad camera(const std::string& patient, const std::string& view) const {
    const auto file = root_ / "patients" / patient / "views" / (view + ".camera.json");
    return camera_from_json(read_json_file(file), file.string());
  }

 private:
  std::shared_ptr<const Image<std::uint8_t>> mask(const std::string& patient,
                                                  const std::string& view) {
    auto it = masks_.find(view);
    if (it != masks_.end()) return it->second;
    auto m = std::make_shared<const Image<std::uint8_t>>(
        read_png8(root_ / "patients" / patient / "views" / (view + ".mask.png")));
    masks_[view] = m;
    return m;
  }

  std::filesystem::path root_;
  std::string cached_patient_;
  std::map<std::string, std::shared_ptr<const Image<std::uint8_t>>> masks_;
};

}  // namespace gimm
