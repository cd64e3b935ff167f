#pragma once
/// Export of a finished gimm dataset (pipeline/dataset.hpp) into the layout of the released
/// reference dataset, so that the reference training and evaluation code reads gimm data.
///
/// Layout written under the output directory (docs/dataset.md, "Reference export"):
///   images/Phys_DRR_<P>_<SYS>_<ViewA>-<ViewB>_{A,B}_0.png  8-bit grey stored as RGB, min-max
///   masks/<same file name>                                  vessel mask, 0/255, RGB
///   npz_scenes/angio_cip_scene_info_<P>.json   image_paths, depth_paths, intrinsics, poses
///                                              (empty strings), pair_infos [[i, j], 1.0, [0]*4]
///   npz_scenes/split_length.txt                mean pairs per scene (integer)
///   dense_labels/angio_cip_dense_labels_<P>.json  {"sample_id", "pairs": {"<SYS>_<View A>-
///                                              <View B>": angles, points, K1, K2, ...}}
///   frame_export_old.json                      sparse labels, one entry per image
///   {train,val,test}_list.txt                  scene names (angio_cip_scene_info_<P>) per split
///   black_list.txt                             empty
///   voxel_spacing_dict.json                    {"<P>": [1, 1, 1]} (3D points are in mm)
/// <P> is the patient id, zero-padded to 4 digits when it is a number (ImageCAS "7" -> "0007");
/// other ids are kept as they are and must not contain '_' (the reference code splits file
/// and scene names at '_'). View names are the clinical ones with spaces replaced by '_' in
/// file names ("AP_Cranial") and kept in the dense-label keys ("RCA_AP Cranial-LAO").
///
/// What differs from the released data, because gimm has other (or more exact) geometry:
///   - Projection: gimm's C-arm camera (perspective by default). K1/K2 are gimm's 3x3 pixel
///     intrinsics, not the reference's orthographic [[1, 0, W/2], [0, 1, H/2], [0, 0, 1]];
///     each pair also carries a "gimm" object with the full 3x4 cameras P1/P2 and the exact F.
///   - 3D points: world millimetres (LPS), not voxel indices; voxel_spacing_dict.json gives
///     spacing 1 so the reference's 3D metric (index difference times spacing) yields mm.
///   - Dense points: "centerline_*" are gimm's dense rows (centerline points that project onto
///     the vessel mask in both views), index-aligned. gimm has no projections of every lumen
///     voxel, so "vessel_points_*" repeat the centerline points (the reference evaluation only
///     counts them).
///   - Images: the full detector. The reference crops columns (to the height when wider, else
///     to the vessel's column extent + 5 px); gimm's detector already frames the system, so
///     nothing is cropped and the labels need no offset. Intensities: the 16-bit view min-max
///     to 0..255 (floor), as the reference does with its float image.
///   - Splits: the gimm manifest's patient split, not the reference's 70/15/15 cut of the
///     sorted scene names. Masks are written for every split (the reference ships them with
///     its test set only; its evaluation reads them).
/// Every file is written atomically; errors name the file and the bad value.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <tuple>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/core/image.hpp"
#include "gimm/dataset/layout.hpp"
#include "gimm/dataset/reader.hpp"
#include "gimm/io/camera_json.hpp"
#include "gimm/io/files.hpp"
#include "gimm/io/png.hpp"
#include "gimm/labels/views.hpp"

namespace gimm {

namespace reference_format {

inline constexpr const char* kProject = "Phys_DRR";
inline constexpr const char* kStudy = "study_001";
inline constexpr const char* kScenePrefix = "angio_cip_scene_info_";
inline constexpr const char* kDensePrefix = "angio_cip_dense_labels_";

/// The patient part of reference names: digits are zero-padded to 4 (as the reference pads
/// ImageCAS ids); anything else is kept, but must not be empty or hold '_', '/', '\\' or
/// white space. `where` names the source (the manifest) in the error.
inline std::string patient_token(const std::string& id, const std::string& where) {
  GIMM_CHECK(!id.empty(), where << ": a patient id is empty");
  const bool digits =
      std::all_of(id.begin(), id.end(), [](unsigned char c) { return c >= '0' && c <= '9'; });
  if (digits) return id.size() >= 4 ? id : std::string(4 - id.size(), '0') + id;
  for (const unsigned char c : id)
    GIMM_CHECK(c != '_' && c != '/' && c != '\\' && c > ' ',
               where << ": patient id '" << id
                     << "' cannot be exported: the reference layout splits names at '_' and "
                        "allows no '/', '\\' or white space in a patient id");
  return id;
}

/// A dataset made from a view list (gimm-dataset --views, manifest parameters view_mode
/// "listed") is not exported: the released layout names a pair by its two view classes, which
/// listed views need not have distinct. `where` names the source in the error.
inline void check_views_exportable(const nlohmann::json& parameters, const std::string& where) {
  const bool listed = parameters.is_object() && parameters.contains("view_mode") &&
                      parameters["view_mode"] == "listed";
  GIMM_CHECK(!listed, where << ": a dataset made from a view list (view_mode 'listed') cannot be "
                               "exported: the released layout names each pair by two distinct "
                               "view classes, which listed views need not have");
}

/// Checks every patient id up front: each must make a token (patient_token) and no two the same
/// token ("7" and "0007"). gimm-dataset calls it before rendering anything, export_reference
/// before writing anything. `where` names the source in the error.
inline void check_patient_ids(const std::vector<std::string>& ids, const std::string& where) {
  std::map<std::string, std::string> owner;  // token -> id
  for (const auto& id : ids) {
    const std::string token = patient_token(id, where);
    const auto [first, fresh] = owner.emplace(token, id);
    GIMM_CHECK(fresh, where << ": patients '" << first->second << "' and '" << id
                            << "' both export as '" << token << "'");
  }
}

/// "AP Cranial" -> "AP_Cranial" (file names); dense-label keys keep the space.
inline std::string underscored(std::string name) {
  std::replace(name.begin(), name.end(), ' ', '_');
  return name;
}

inline std::string pair_name(const std::string& system, const std::string& view_a,
                             const std::string& view_b) {
  return system + "_" + underscored(view_a) + "-" + underscored(view_b);
}

inline std::string dense_key(const std::string& system, const std::string& view_a,
                             const std::string& view_b) {
  return system + "_" + view_a + "-" + view_b;
}

inline std::string image_name(const std::string& patient, const std::string& pair, char side) {
  return std::string(kProject) + "_" + patient + "_" + pair + "_" + side + "_0.png";
}

/// 16-bit grey -> 8-bit min-max (floor), as three equal channels.
inline Image<Rgb8> min_max_rgb8(const Image<std::uint16_t>& in) {
  Image<Rgb8> out(in.rows(), in.cols());
  if (in.empty()) return out;
  const auto [lo_it, hi_it] = std::minmax_element(in.storage().begin(), in.storage().end());
  const std::uint32_t lo = *lo_it, range = *hi_it - *lo_it;
  for (std::size_t p = 0; p < in.size(); ++p) {
    const auto v =
        range ? static_cast<std::uint8_t>((in.data()[p] - lo) * 255u / range) : std::uint8_t{0};
    out.data()[p] = Rgb8{v, v, v};
  }
  return out;
}

/// Mask (any non-zero is vessel) -> 0/255 in three equal channels.
inline Image<Rgb8> mask_rgb8(const Image<std::uint8_t>& in) {
  Image<Rgb8> out(in.rows(), in.cols());
  for (std::size_t p = 0; p < in.size(); ++p) {
    const std::uint8_t v = in.data()[p] ? 255 : 0;
    out.data()[p] = Rgb8{v, v, v};
  }
  return out;
}

}  // namespace reference_format

namespace detail {

/// A view name from a pair file: a plain file stem inside views/ (no path tricks).
inline std::string ref_view_name(const nlohmann::json& pair, const char* key,
                                 const std::string& where) {
  const std::string name = json_string(pair, key, where);
  GIMM_CHECK_AS(FormatError,
                !name.empty() && name != "." && name != ".." &&
                    name.find_first_of("/\\") == std::string::npos,
                where << ": '" << key << "' must name a view file, got '" << name << "'");
  return name;
}

/// One rendered view, as the reference export needs it.
struct RefView {
  std::string file;  ///< views/<name> without extension
  std::string system, view_name;
  int view_class = 0;
  double primary_deg = 0, secondary_deg = 0;
  Camerad camera;
};

inline RefView read_ref_view(const std::filesystem::path& views_dir, const std::string& name,
                             int pair_view_class, const std::string& pair_where) {
  RefView v;
  v.file = name;
  const std::filesystem::path path = views_dir / (name + ".camera.json");
  const std::string where = path.string();
  const nlohmann::json j = read_json_file(path);
  v.camera = camera_from_json(j, where);
  v.system = json_string(j, "system", where);
  v.view_name = json_string(j, "view_name", where);
  v.view_class = json_int(j, "view_class", where);
  v.primary_deg = json_number(j, "primary_deg", where);
  v.secondary_deg = json_number(j, "secondary_deg", where);
  GIMM_CHECK_AS(FormatError, v.view_class >= 1 && v.view_class <= 11,
                where << ": 'view_class' must be in 1..11, got " << v.view_class);
  const ViewClass& c = view_class(v.view_class);
  GIMM_CHECK_AS(FormatError, v.view_name == c.name && v.system == to_string(c.system),
                where << ": view class " << v.view_class << " is " << to_string(c.system) << " '"
                      << c.name << "', but the file says " << v.system << " '" << v.view_name
                      << "'");
  GIMM_CHECK_AS(FormatError, pair_view_class == v.view_class,
                pair_where << ": view '" << name << "' has class " << pair_view_class
                           << " there but " << v.view_class << " in " << where);
  return v;
}

/// An 8-bit RGB copy of views/<name><suffix>, checked against the camera's detector size.
inline Image<Rgb8> read_ref_image(const std::filesystem::path& path, const Camerad& camera,
                                  bool mask) {
  Image<Rgb8> out;
  int rows = 0, cols = 0;
  if (mask) {
    const Image<std::uint8_t> m = read_png8(path);
    rows = m.rows();
    cols = m.cols();
    out = reference_format::mask_rgb8(m);
  } else {
    const Image<std::uint16_t> im = read_png16(path);
    rows = im.rows();
    cols = im.cols();
    out = reference_format::min_max_rgb8(im);
  }
  GIMM_CHECK_AS(FormatError, rows == camera.rows() && cols == camera.cols(),
                "'" << path.string() << "' is " << rows << " x " << cols
                    << " but its camera's detector is " << camera.rows() << " x " << camera.cols());
  return out;
}

}  // namespace detail

/// Converts the finished gimm dataset in `dataset_dir` (manifest.json, patients/<id>/...)
/// into the reference layout under `out_dir` (see the file comment). Patients whose manifest
/// status is not "ok" are skipped, as the reference skips samples it could not process.
/// Existing files of the same names are replaced; nothing else in `out_dir` is touched. This
/// overload takes the dataset's manifest as given (`mwhere` names it in errors): a run exports
/// before it renames its manifest into place, so that the two appear together.
inline void export_reference(const std::filesystem::path& dataset_dir,
                             const nlohmann::json& manifest, const std::string& mwhere,
                             const std::filesystem::path& out_dir) {
  namespace fs = std::filesystem;
  namespace rf = reference_format;
  using nlohmann::json;
  const DatasetLayout layout(dataset_dir);
  check_dataset_format(manifest, mwhere);
  rf::check_views_exportable(manifest.value("parameters", json()), mwhere);
  const json& patients = json_field(manifest, "patients", mwhere);
  GIMM_CHECK_AS(FormatError, patients.is_array(),
                mwhere << ": 'patients' must be an array, got " << patients.type_name());

  json frames = json::array();
  json spacing = json::object();
  std::map<std::string, std::vector<std::string>> lists{{"train", {}}, {"val", {}}, {"test", {}}};
  std::size_t total_pairs = 0, scenes = 0;

  // Every record's id and split first: a bad one fails before any file is written.
  std::vector<const json*> ok;
  std::vector<std::string> ids;
  for (const json& record : patients) {
    const std::string status = record.is_object() ? record.value("status", "") : "";
    if (status != "ok") continue;
    const std::string id = json_string(record, "id", mwhere);
    const std::string pwhere = mwhere + " (patient '" + id + "')";
    const std::string split = json_string(record, "split", pwhere);
    GIMM_CHECK_AS(FormatError, lists.count(split),
                  pwhere << ": 'split' must be train, val or test, got '" << split << "'");
    ok.push_back(&record);
    ids.push_back(id);
  }
  rf::check_patient_ids(ids, mwhere);
  for (const char* sub : {"images", "masks", "npz_scenes", "dense_labels"})
    create_folders(out_dir / sub);

  for (const json* r : ok) {
    const json& record = *r;
    const std::string id = record["id"].get<std::string>();
    const std::string pwhere = mwhere + " (patient '" + id + "')";
    const std::string split = record["split"].get<std::string>();
    const std::string token = rf::patient_token(id, pwhere);

    const fs::path views_dir = layout.views_dir(id);
    const fs::path pairs_dir = layout.pairs_dir(id);
    GIMM_CHECK_AS(IoError, fs::is_directory(pairs_dir),
                  pwhere << ": '" << pairs_dir.string() << "' does not exist");
    std::vector<fs::path> pair_files;
    for (const auto& e : fs::directory_iterator(pairs_dir))
      if (e.is_regular_file() && e.path().extension() == ".json") pair_files.push_back(e.path());

    struct Pair {
      std::tuple<int, int, int> order;  // system (RCA first), class A, class B
      fs::path file;
      json labels;
      detail::RefView a, b;
    };
    std::vector<Pair> pairs;
    for (const auto& file : pair_files) {
      const std::string where = file.string();
      Pair p;
      p.file = file;
      p.labels = read_json_file(file);
      const std::string va = detail::ref_view_name(p.labels, "view_a", where);
      const std::string vb = detail::ref_view_name(p.labels, "view_b", where);
      p.a = detail::read_ref_view(views_dir, va, json_int(p.labels, "view_class_a", where), where);
      p.b = detail::read_ref_view(views_dir, vb, json_int(p.labels, "view_class_b", where), where);
      GIMM_CHECK_AS(FormatError, p.a.system == p.b.system && p.a.view_class != p.b.view_class,
                    where << ": a pair needs two view classes of one system, got " << p.a.system
                          << " '" << p.a.view_name << "' and " << p.b.system << " '"
                          << p.b.view_name << "'");
      p.order = {p.a.system == "RCA" ? 0 : 1, p.a.view_class, p.b.view_class};
      pairs.push_back(std::move(p));
    }
    std::sort(pairs.begin(), pairs.end(),
              [](const Pair& x, const Pair& y) { return x.order < y.order; });
    for (std::size_t k = 1; k < pairs.size(); ++k)
      GIMM_CHECK_AS(FormatError, pairs[k].order != pairs[k - 1].order,
                    "'" << pairs[k - 1].file.string() << "' and '" << pairs[k].file.string()
                        << "' are the same view pair (" << pairs[k].a.system << " "
                        << pairs[k].a.view_name << " - " << pairs[k].b.view_name
                        << "); the reference layout names a pair by its views");
    if (pairs.empty()) continue;  // the reference writes no scene for a patient without pairs

    json image_paths = json::array(), pair_infos = json::array();
    json dense_pairs = json::object();
    for (const Pair& p : pairs) {
      const std::string where = p.file.string();
      const std::string& sys = p.a.system;
      const std::string name = rf::pair_name(sys, p.a.view_name, p.b.view_name);
      const std::string file_a = rf::image_name(token, name, 'A');
      const std::string file_b = rf::image_name(token, name, 'B');
      for (const auto& [view, file] :
           {std::pair<const detail::RefView*, std::string>{&p.a, file_a}, {&p.b, file_b}}) {
        const fs::path src = views_dir / view->file;
        write_png(out_dir / "images" / file,
                  detail::read_ref_image(src.string() + ".png", view->camera, false));
        write_png(out_dir / "masks" / file,
                  detail::read_ref_image(src.string() + ".mask.png", view->camera, true));
      }

      // Dense rows -> index-aligned 2D/3D lists; sparse indices -> per-image landmarks.
      const std::vector<Correspondence> dense = dense_labels_from_json(p.labels, where);
      json pts_a = json::array(), pts_b = json::array(), pts_3d = json::array();
      for (const Correspondence& c : dense) {
        pts_a.push_back({c.a.x(), c.a.y()});
        pts_b.push_back({c.b.x(), c.b.y()});
        pts_3d.push_back({c.world.x(), c.world.y(), c.world.z()});
      }
      const json& sparse = json_field(p.labels, "sparse", where);
      GIMM_CHECK_AS(FormatError, sparse.is_array(),
                    where << ": 'sparse' must be an array, got " << sparse.type_name());
      json categories = json::array(), sparse_a = json::array(), sparse_b = json::array();
      for (std::size_t k = 0; k < sparse.size(); ++k) {
        const json& s = sparse[k];
        GIMM_CHECK_AS(FormatError,
                      s.is_number_integer() && s.get<long long>() >= 0 &&
                          static_cast<std::size_t>(s.get<long long>()) < dense.size(),
                      where << ": sparse entry " << k << " must index a dense row (0.."
                            << dense.size() << "), got " << s.dump());
        const std::size_t row = s.get<std::size_t>();
        categories.push_back(sys + "_" + (k < 10 ? "0" : "") + std::to_string(k));
        sparse_a.push_back(pts_a[row]);
        sparse_b.push_back(pts_b[row]);
      }
      for (const auto& [side, pts] :
           {std::pair<const char*, const json*>{"A", &sparse_a}, {"B", &sparse_b}})
        frames.push_back(
            {{"project", rf::kProject},
             {"patient", token},
             {"video_name", name + "_" + side},
             {"study", rf::kStudy},
             {"label",
              {{"cip",
                {{"multi_branch",
                  {{"data", json::array({{{"categories", categories}, {"pts", *pts}}})}}}}}}}});

      const json K1 = gimm::matrix_to_json(p.a.camera.K());
      const json K2 = gimm::matrix_to_json(p.b.camera.K());
      dense_pairs[rf::dense_key(sys, p.a.view_name, p.b.view_name)] = {
          {"primary_A", p.a.primary_deg},
          {"secondary_A", p.a.secondary_deg},
          {"primary_B", p.b.primary_deg},
          {"secondary_B", p.b.secondary_deg},
          {"vessel_points_3d", pts_3d},
          {"vessel_points_A", pts_a},
          {"vessel_points_B", pts_b},
          {"centerline_3d", pts_3d},
          {"centerline_A", pts_a},
          {"centerline_B", pts_b},
          {"K1", K1},
          {"K2", K2},
          {"gimm",
           {{"source", fs::relative(p.file, dataset_dir).generic_string()},
            {"camera_model", to_string(p.a.camera.model())},
            {"points_3d", "world mm (LPS), not voxel indices"},
            {"P1", gimm::matrix_to_json(p.a.camera.P())},
            {"P2", gimm::matrix_to_json(p.b.camera.P())},
            {"F", json_field(p.labels, "F", where)},
            {"F_convention", "x_B^T F x_A = 0, pixels"},
            {"view_class_A", p.a.view_class},
            {"view_class_B", p.b.view_class},
            {"sparse", sparse}}}};

      const std::size_t i = image_paths.size();
      image_paths.push_back(file_a);
      image_paths.push_back(file_b);
      pair_infos.push_back({json::array({i, i + 1}), 1.0, json::array({0.0, 0.0, 0.0, 0.0})});
    }

    const std::size_t n = image_paths.size();
    const json empty(n, "");
    const std::string scene = rf::kScenePrefix + token;
    write_json_file(out_dir / "npz_scenes" / (scene + ".json"),
                    {{"image_paths", image_paths},
                     {"depth_paths", empty},
                     {"intrinsics", empty},
                     {"poses", empty},
                     {"pair_infos", pair_infos}},
                    2);
    write_json_file(out_dir / "dense_labels" / (rf::kDensePrefix + token + ".json"),
                    {{"sample_id", id}, {"pairs", dense_pairs}}, -1);
    spacing[token] = {1.0, 1.0, 1.0};
    lists[split].push_back(scene);
    total_pairs += pairs.size();
    ++scenes;
  }

  write_json_file(out_dir / "frame_export_old.json", frames, -1);
  write_json_file(out_dir / "voxel_spacing_dict.json", spacing, 2);
  for (auto& [split, names] : lists) {
    std::sort(names.begin(), names.end());
    std::string text;
    for (const auto& s : names) text += s + "\n";
    write_file_atomic(out_dir / (split + "_list.txt"), text);
  }
  write_file_atomic(out_dir / "black_list.txt", std::string());
  write_file_atomic(out_dir / "npz_scenes" / "split_length.txt",
                    std::to_string(scenes ? total_pairs / scenes : 0));
}

/// export_reference of the dataset's manifest.json.
inline void export_reference(const std::filesystem::path& dataset_dir,
                             const std::filesystem::path& out_dir) {
  const std::filesystem::path manifest_path = DatasetLayout(dataset_dir).manifest();
  GIMM_CHECK_AS(IoError, std::filesystem::exists(manifest_path),
                "export_reference: '" << manifest_path.string()
                                      << "' does not exist (a sharded run needs 'gimm-dataset "
                                         "merge' first)");
  export_reference(dataset_dir, read_json_file(manifest_path), manifest_path.string(), out_dir);
}

}  // namespace gimm
