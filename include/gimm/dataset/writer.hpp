#pragma once
/// The one writer of a gimm dataset (layout.hpp): the JSON of views, pairs and records, and the
/// files, each written atomically (io/files.hpp), so a reader never sees half a file and a
/// killed run leaves only temporaries, which the run removes (run.hpp). A patient is written
/// into its staging folder (a writer over DatasetLayout::with_patient_suffix); the manifest and
/// split lists of a run are staged together (stage_run_files) and renamed into place at once.
#include <algorithm>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "gimm/anatomy/components.hpp"
#include "gimm/core/image.hpp"
#include "gimm/dataset/layout.hpp"
#include "gimm/io/camera_json.hpp"
#include "gimm/io/files.hpp"
#include "gimm/io/npy.hpp"
#include "gimm/io/png.hpp"
#include "gimm/labels/correspondence.hpp"
#include "gimm/labels/view_protocol.hpp"

namespace gimm {

/// "RCA_03": the name of view `index` of a coronary system.
inline std::string view_name(const std::string& system, std::size_t index) {
  return system + "_" + (index < 10 ? "0" : "") + std::to_string(index);
}

/// "RCA_03-07": the pair of views a and b of one system.
inline std::string pair_name(const std::string& system, std::size_t a, std::size_t b) {
  return view_name(system, a) + "-" + (b < 10 ? "0" : "") + std::to_string(b);
}

/// Every centerline point of the system in one view (column arrays, in the order of
/// centerlines.json's branches and points).
inline nlohmann::json view_points_json(const std::vector<LabelPoint>& points,
                                       const std::vector<ProjectedPoint>& view) {
  nlohmann::json u = nlohmann::json::array(), v = u, depth = u, in_image = u, on_mask = u,
                 overlap = u, visible = u, branch = u, index = u;
  for (std::size_t n = 0; n < points.size(); ++n) {
    u.push_back(view[n].uv.x());
    v.push_back(view[n].uv.y());
    depth.push_back(view[n].depth);
    in_image.push_back(view[n].in_image ? 1 : 0);
    on_mask.push_back(view[n].on_mask ? 1 : 0);
    overlap.push_back(view[n].overlap);
    visible.push_back(view[n].visible ? 1 : 0);
    branch.push_back(points[n].branch);
    index.push_back(points[n].index);
  }
  return {{"u", u},
          {"v", v},
          {"depth_mm", depth},
          {"in_image", in_image},
          {"on_mask", on_mask},
          {"overlap", overlap},
          {"visible", visible},
          {"branch", branch},
          {"point", index}};
}

/// A pair file: views, classes, F, dense labels (columns named in dense_fields, the reader's
/// rule) and the sparse label indices.
inline nlohmann::json pair_json(const PairLabels& labels, const SampledView& a,
                                const SampledView& b, const std::string& name_a,
                                const std::string& name_b) {
  nlohmann::json dense = nlohmann::json::array();
  for (const auto& c : labels.dense)
    dense.push_back({c.a.x(), c.a.y(), c.b.x(), c.b.y(), c.world.x(), c.world.y(), c.world.z(),
                     c.branch, c.index, c.radius});
  return {{"view_a", name_a},
          {"view_b", name_b},
          {"view_class_a", a.view_class},
          {"view_class_b", b.view_class},
          {"F", gimm::matrix_to_json(labels.F)},
          {"F_convention", "x_b^T F x_a = 0, pixels"},
          {"dense_fields",
           {"u_a", "v_a", "u_b", "v_b", "x_mm", "y_mm", "z_mm", "branch", "point", "radius_mm"}},
          {"dense", dense},
          {"sparse", labels.sparse}};
}

/// What the LCA/RCA split kept of the label: every component, and the voxels and components left
/// in neither system (specks, trees beyond the two largest). Deterministic, so part of the
/// record.
inline nlohmann::json label_json(const CoronarySplit& split) {
  const int kept = (split.lca_voxels > 0 ? 1 : 0) + (split.rca_voxels > 0 ? 1 : 0);
  return {{"voxels", split.label_voxels},
          {"components", split.components},
          {"dropped_components", split.components - kept},
          {"dropped_voxels", split.dropped_voxels},
          {"dropped_fraction", split.dropped_fraction()}};
}

/// One view's contents as they go to disk.
struct ViewFiles {
  Image<std::uint16_t> image;                    ///< the angiogram, 16-bit
  Image<std::uint8_t> mask;                      ///< nonzero = vessel (written 0/255)
  const Image<std::uint8_t>* overlap = nullptr;  ///< vessel passages per pixel (mesh mode)
  const Image<float>* line_integrals = nullptr;  ///< float32 optical depth (optional)
  /// The formed angiogram (render/angiogram_formation.hpp), levels of `formed_bits` bits, and
  /// its exposed field (nonzero = exposed, written 0/255); optional, both or neither.
  const Image<std::uint16_t>* formed = nullptr;
  int formed_bits = 8;
  const Image<std::uint8_t>* field = nullptr;
  nlohmann::json camera;  ///< camera, view class, angles
  nlohmann::json points;  ///< view_points_json
};

class DatasetWriter {
 public:
  explicit DatasetWriter(std::filesystem::path root) : layout_(std::move(root)) {}
  explicit DatasetWriter(DatasetLayout layout) : layout_(std::move(layout)) {}
  const DatasetLayout& layout() const { return layout_; }

  /// The patient's views/ and pairs/ folders.
  void create_patient(const std::string& patient) const {
    create_folders(layout_.views_dir(patient));
    create_folders(layout_.pairs_dir(patient));
  }

  void write_view(const std::string& patient, const std::string& view, ViewFiles files) const {
    write_png(layout_.view_image(patient, view), files.image);
    for (auto& px : files.mask.storage()) px = px ? 255 : 0;
    write_png(layout_.view_mask(patient, view), files.mask);
    if (files.overlap) write_png(layout_.view_overlap(patient, view), *files.overlap);
    if (files.line_integrals)
      write_npy(layout_.view_line_integrals(patient, view), *files.line_integrals);
    if (files.formed) {
      GIMM_CHECK(files.field, "write_view: a formed angiogram needs its field mask");
      if (files.formed_bits == 16) {
        write_png(layout_.view_formed(patient, view), *files.formed);
      } else {
        GIMM_CHECK(files.formed_bits == 8,
                   "write_view: formed angiograms are 8 or 16 bits, got " << files.formed_bits);
        Image<std::uint8_t> levels(files.formed->rows(), files.formed->cols());
        for (std::size_t p = 0; p < levels.size(); ++p)
          levels.data()[p] = static_cast<std::uint8_t>(std::min<int>(files.formed->data()[p], 255));
        write_png(layout_.view_formed(patient, view), levels);
      }
      Image<std::uint8_t> field = *files.field;
      for (auto& px : field.storage()) px = px ? 255 : 0;
      write_png(layout_.view_field(patient, view), field);
    }
    write_json_file(layout_.view_camera(patient, view), files.camera);
    write_json_file(layout_.view_points(patient, view), files.points, -1);
  }

  void write_pair(const std::string& patient, const std::string& pair,
                  const nlohmann::json& labels) const {
    write_json_file(layout_.pair_labels(patient, pair), labels, -1);
  }

  void write_centerlines(const std::string& patient, const nlohmann::json& centerlines) const {
    write_json_file(layout_.centerlines(patient), centerlines, -1);
  }

  /// Written last: its presence means the patient is complete (resume skips it).
  void write_done_record(const std::string& patient, const nlohmann::json& record) const {
    write_json_file(layout_.done_record(patient), record);
  }

  void write_manifest(const nlohmann::json& manifest, const Shard& shard = {}) const {
    write_json_file(layout_.manifest(shard), manifest);
  }

  /// splits/{train,val,test}.txt: the ids of the "ok" patients of each split, in record order;
  /// the three lists are renamed into place together.
  void write_splits(const nlohmann::json& patients) const {
    StagedFiles files;
    stage_splits(files, patients);
    files.commit();
  }

  /// The run's own files staged in `files`, to be renamed into place together by files.commit()
  /// (or left as they were if the run fails first): the manifest and, for a whole run (not one
  /// shard), the split lists of its patients.
  void stage_run_files(StagedFiles& files, const nlohmann::json& manifest,
                       const Shard& shard = {}) const {
    if (!shard.sharded()) stage_splits(files, manifest.at("patients"));
    // Renamed last: a manifest in place says the run is complete.
    write_json_file(files.path_for(layout_.manifest(shard)), manifest);
  }

 private:
  void stage_splits(StagedFiles& files, const nlohmann::json& patients) const {
    files.create_folder(layout_.splits_dir());
    for (const char* split : {"train", "val", "test"}) {
      std::string text;
      for (const auto& p : patients)
        if (p.value("status", "") == "ok" && p.value("split", "") == split)
          text += p["id"].get<std::string>() + "\n";
      write_file_atomic(files.path_for(layout_.split_list(split)), text);
    }
  }

 private:
  DatasetLayout layout_;
};

}  // namespace gimm
