#pragma once
/// The on-disk layout of a gimm dataset (docs/dataset.md), defined here and nowhere else:
///
///   manifest.json (or manifest.shard-I-of-N.json)   format, parameters, input, patients
///   splits/{train,val,test}.txt                      patient ids, one per line
///   patients/<id>/centerlines.json                   centerlines extracted from the label
///   patients/<id>/views/<view>.png                   16-bit angiogram (Beer-Lambert, min-max)
///   patients/<id>/views/<view>.mask.png              8-bit projected vessel mask (0/255)
///   patients/<id>/views/<view>.overlap.png           vessel passages per pixel (mesh mode)
///   patients/<id>/views/<view>.npy                   float32 line integrals (--line-integrals)
///   patients/<id>/views/<view>.formed.png            8/16-bit formed angiogram (--formation;
///                                                    the manifest's "images" lists "formed")
///   patients/<id>/views/<view>.field.png             8-bit exposed field (0/255; --formation)
///   patients/<id>/views/<view>.camera.json           camera, view class, angles, PNG window
///   patients/<id>/views/<view>.points.json           projected centerline points
///   patients/<id>/pairs/<pair>.json                  pair labels (dense, sparse, F, classes)
///   patients/<id>/done.json                          the patient's record, written last
///   reference/                                       --export reference (the released layout)
///
/// While a patient is made, its files go to patients/<id>.tmp.<host>.<pid>/ (with_patient_suffix),
/// renamed to patients/<id>/ when complete: a patient's folder is there whole or not at all.
///
/// Views are named <SYS>_<nn> (RCA_00), pairs <SYS>_<nn>-<mm>; a pair id is
/// "<patient>/<pair>", e.g. "phantom-0000/LCA_00-01".
#include <filesystem>
#include <string>
#include <utility>

#include "gimm/core/error.hpp"

namespace gimm {

/// The manifest's "format": written by the dataset writer; the reader takes it and /1.
/// /2 lists the images every view has ("images": "drr", and "formed" and "field" with a
/// formation stage); a /1 manifest has no list, and its views have what its parameters say
/// (dataset_images).
inline constexpr const char* kDatasetFormat = "gimm-dataset/2";
inline constexpr const char* kDatasetFormatV1 = "gimm-dataset/1";

/// One process's share of the patients: patient k (in id order) belongs to shard k mod count.
struct Shard {
  int index = 0, count = 1;
  bool sharded() const { return count > 1; }
};

/// "<patient>/<pair>" split in two; a clear error for anything else.
inline std::pair<std::string, std::string> split_pair_id(const std::string& id) {
  const auto slash = id.find('/');
  GIMM_CHECK(slash != std::string::npos && slash > 0 && slash + 1 < id.size() &&
                 id.find('/', slash + 1) == std::string::npos,
             "pair id must be <patient>/<pair>, got '" << id << "'");
  std::pair<std::string, std::string> parts{id.substr(0, slash), id.substr(slash + 1)};
  for (const std::string& part : {parts.first, parts.second})
    GIMM_CHECK(part != "." && part != ".." &&
                   part.find_first_of(std::string("\\\0", 2)) == std::string::npos,
               "pair id must be <patient>/<pair> of folder names, got '" << id << "'");
  return parts;
}

/// Refuses a `kind` name ("patient id", "view") that is no single file or folder name ("",
/// ".", "..", a '/', a '\\' or a NUL): a name read from a file ("../../etc" in a manifest or a
/// pair file) must not reach outside its folder.
inline void check_plain_name(const char* kind, const std::string& name, const std::string& where) {
  GIMM_CHECK_AS(FormatError,
                !name.empty() && name != "." && name != ".." &&
                    name.find_first_of(std::string("/\\\0", 3)) == std::string::npos,
                where << ": " << kind << " '" << name
                      << "' is not a folder name (no '/', '\\', '..' or empty id)");
}

inline void check_patient_name(const std::string& id, const std::string& where) {
  check_plain_name("patient id", id, where);
}

class DatasetLayout {
 public:
  explicit DatasetLayout(std::filesystem::path root) : root_(std::move(root)) {}
  const std::filesystem::path& root() const { return root_; }

  std::filesystem::path manifest(const Shard& shard = {}) const {
    return root_ / (shard.sharded() ? "manifest.shard-" + std::to_string(shard.index) + "-of-" +
                                          std::to_string(shard.count) + ".json"
                                    : std::string("manifest.json"));
  }
  /// The prefix every shard manifest's file name starts with.
  static constexpr const char* kShardManifestPrefix = "manifest.shard-";
  std::filesystem::path splits_dir() const { return root_ / "splits"; }
  std::filesystem::path split_list(const std::string& split) const {
    return splits_dir() / (split + ".txt");
  }
  std::filesystem::path reference_dir() const { return root_ / "reference"; }

  std::filesystem::path patients_dir() const { return root_ / "patients"; }
  std::filesystem::path patient_dir(const std::string& patient) const {
    return patients_dir() / (patient + patient_suffix_);
  }
  /// This layout with every patient's folder "<id><suffix>" instead of "<id>": where a patient is
  /// made before it is renamed into place (pipeline/patient.hpp, generate_patient).
  DatasetLayout with_patient_suffix(const std::string& suffix) const {
    DatasetLayout staged = *this;
    staged.patient_suffix_ = suffix;
    return staged;
  }
  std::filesystem::path views_dir(const std::string& patient) const {
    return patient_dir(patient) / "views";
  }
  std::filesystem::path pairs_dir(const std::string& patient) const {
    return patient_dir(patient) / "pairs";
  }
  std::filesystem::path centerlines(const std::string& patient) const {
    return patient_dir(patient) / "centerlines.json";
  }
  std::filesystem::path done_record(const std::string& patient) const {
    return patient_dir(patient) / "done.json";
  }

  /// A view's files: its stem plus ".png", ".mask.png", ".overlap.png", ".npy", ".formed.png",
  /// ".field.png", ".camera.json", ".points.json".
  std::filesystem::path view_stem(const std::string& patient, const std::string& view) const {
    return views_dir(patient) / view;
  }
  std::filesystem::path view_image(const std::string& patient, const std::string& view) const {
    return with_suffix(patient, view, ".png");
  }
  std::filesystem::path view_mask(const std::string& patient, const std::string& view) const {
    return with_suffix(patient, view, ".mask.png");
  }
  std::filesystem::path view_overlap(const std::string& patient, const std::string& view) const {
    return with_suffix(patient, view, ".overlap.png");
  }
  std::filesystem::path view_line_integrals(const std::string& patient,
                                            const std::string& view) const {
    return with_suffix(patient, view, ".npy");
  }
  std::filesystem::path view_formed(const std::string& patient, const std::string& view) const {
    return with_suffix(patient, view, ".formed.png");
  }
  std::filesystem::path view_field(const std::string& patient, const std::string& view) const {
    return with_suffix(patient, view, ".field.png");
  }
  std::filesystem::path view_camera(const std::string& patient, const std::string& view) const {
    return with_suffix(patient, view, ".camera.json");
  }
  std::filesystem::path view_points(const std::string& patient, const std::string& view) const {
    return with_suffix(patient, view, ".points.json");
  }
  std::filesystem::path pair_labels(const std::string& patient, const std::string& pair) const {
    return pairs_dir(patient) / (pair + ".json");
  }
  std::filesystem::path pair_labels(const std::string& pair_id) const {
    const auto [patient, pair] = split_pair_id(pair_id);
    return pair_labels(patient, pair);
  }

 private:
  std::filesystem::path with_suffix(const std::string& patient, const std::string& view,
                                    const char* suffix) const {
    return views_dir(patient) / (view + suffix);
  }
  std::filesystem::path root_;
  std::string patient_suffix_;
};

}  // namespace gimm
