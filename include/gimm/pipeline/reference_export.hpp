#pragma once
/// Export of a finished gimm dataset (pipeline/patient.hpp) into the layout of the released
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

inline RefView read_ref_view(const DatasetLayout& layout, const std::string& patient,
                             const std::string& name, int pair_view_class,
                             const std::string& pair_where) {
  RefView v;
  v.file = name;
  const std::filesystem::path path = layout.view_camera(patient, name);
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

/// A patient the export writes: its id, split and reference token.
struct RefPatient {
  std::string id, split, token;
};

/// The patients whose manifest status is "ok", each id and split checked: a bad one fails
/// before any file is written.
inline std::vector<RefPatient> exportable_patients(const nlohmann::json& manifest,
                                                   const std::string& mwhere) {
  check_dataset_format(manifest, mwhere);
  reference_format::check_views_exportable(manifest.value("parameters", nlohmann::json()), mwhere);
  const nlohmann::json& patients = json_field(manifest, "patients", mwhere);
  GIMM_CHECK_AS(FormatError, patients.is_array(),
                mwhere << ": 'patients' must be an array, got " << patients.type_name());
  std::vector<RefPatient> out;
  std::vector<std::string> ids;
  for (const nlohmann::json& record : patients) {
    const std::string status = record.is_object() ? record.value("status", "") : "";
    if (status != "ok") continue;
    RefPatient p;
    p.id = json_string(record, "id", mwhere);
    const std::string pwhere = mwhere + " (patient '" + p.id + "')";
    p.split = json_string(record, "split", pwhere);
    GIMM_CHECK_AS(FormatError, p.split == "train" || p.split == "val" || p.split == "test",
                  pwhere << ": 'split' must be train, val or test, got '" << p.split << "'");
    p.token = reference_format::patient_token(p.id, pwhere);
    out.push_back(p);
    ids.push_back(p.id);
  }
  reference_format::check_patient_ids(ids, mwhere);
  return out;
}

/// One pair of a patient with both views, as the export orders them.
struct RefPair {
  std::tuple<int, int, int> order;  ///< system (RCA first), class A, class B
  std::filesystem::path file;
  nlohmann::json labels;
  RefView a, b;
};

/// The patient's pairs in the reference's order (RCA first, then by view classes); two files
/// of one view pair are refused (the reference names a pair by its views).
inline std::vector<RefPair> read_ref_pairs(const DatasetReader& reader, const RefPatient& patient,
                                           const std::string& pwhere) {
  const std::filesystem::path pairs_dir = reader.layout().pairs_dir(patient.id);
  GIMM_CHECK_AS(IoError, std::filesystem::is_directory(pairs_dir),
                pwhere << ": '" << pairs_dir.string() << "' does not exist");
  std::vector<RefPair> pairs;
  for (const std::string& stem : reader.pairs_of(patient.id)) {
    RefPair p;
    p.file = reader.layout().pair_labels(patient.id, stem);
    const std::string where = p.file.string();
    p.labels = reader.pair_json(patient.id + "/" + stem);
    const std::string va = ref_view_name(p.labels, "view_a", where);
    const std::string vb = ref_view_name(p.labels, "view_b", where);
    p.a = read_ref_view(reader.layout(), patient.id, va, json_int(p.labels, "view_class_a", where),
                        where);
    p.b = read_ref_view(reader.layout(), patient.id, vb, json_int(p.labels, "view_class_b", where),
                        where);
    GIMM_CHECK_AS(FormatError, p.a.system == p.b.system && p.a.view_class != p.b.view_class,
                  where << ": a pair needs two view classes of one system, got " << p.a.system
                        << " '" << p.a.view_name << "' and " << p.b.system << " '" << p.b.view_name
                        << "'");
    p.order = {p.a.system == "RCA" ? 0 : 1, p.a.view_class, p.b.view_class};
    pairs.push_back(std::move(p));
  }
  std::sort(pairs.begin(), pairs.end(),
            [](const RefPair& x, const RefPair& y) { return x.order < y.order; });
  for (std::size_t k = 1; k < pairs.size(); ++k)
    GIMM_CHECK_AS(FormatError, pairs[k].order != pairs[k - 1].order,
                  "'" << pairs[k - 1].file.string() << "' and '" << pairs[k].file.string()
                      << "' are the same view pair (" << pairs[k].a.system << " "
                      << pairs[k].a.view_name << " - " << pairs[k].b.view_name
                      << "); the reference layout names a pair by its views");
  return pairs;
}

/// A pair's dense rows as index-aligned 2D/3D lists.
struct RefPoints {
  nlohmann::json a = nlohmann::json::array(), b = nlohmann::json::array(),
                 world = nlohmann::json::array();
};

inline RefPoints ref_points(const RefPair& p) {
  RefPoints out;
  for (const Correspondence& c : dense_labels_from_json(p.labels, p.file.string())) {
    out.a.push_back({c.a.x(), c.a.y()});
    out.b.push_back({c.b.x(), c.b.y()});
    out.world.push_back({c.world.x(), c.world.y(), c.world.z()});
  }
  return out;
}

/// The pair's two frame_export_old.json entries: its sparse labels as per-image landmarks.
inline void add_ref_frames(const RefPair& p, const RefPoints& pts, const std::string& token,
                           const std::string& name, nlohmann::json& frames) {
  using nlohmann::json;
  const std::string where = p.file.string();
  const json& sparse = json_field(p.labels, "sparse", where);
  GIMM_CHECK_AS(FormatError, sparse.is_array(),
                where << ": 'sparse' must be an array, got " << sparse.type_name());
  json categories = json::array(), sparse_a = json::array(), sparse_b = json::array();
  for (std::size_t k = 0; k < sparse.size(); ++k) {
    const json& s = sparse[k];
    GIMM_CHECK_AS(FormatError,
                  s.is_number_integer() && s.get<long long>() >= 0 &&
                      static_cast<std::size_t>(s.get<long long>()) < pts.a.size(),
                  where << ": sparse entry " << k << " must index a dense row (0.." << pts.a.size()
                        << "), got " << s.dump());
    const std::size_t row = s.get<std::size_t>();
    categories.push_back(p.a.system + "_" + (k < 10 ? "0" : "") + std::to_string(k));
    sparse_a.push_back(pts.a[row]);
    sparse_b.push_back(pts.b[row]);
  }
  for (const auto& [side, landmarks] :
       {std::pair<const char*, const json*>{"A", &sparse_a}, {"B", &sparse_b}})
    frames.push_back(
        {{"project", reference_format::kProject},
         {"patient", token},
         {"video_name", name + "_" + side},
         {"study", reference_format::kStudy},
         {"label",
          {{"cip",
            {{"multi_branch",
              {{"data", json::array({{{"categories", categories}, {"pts", *landmarks}}})}}}}}}}});
}

/// The pair's dense-label entry: angles, points, intrinsics, and gimm's exact geometry.
inline nlohmann::json ref_dense_entry(const RefPair& p, const RefPoints& pts,
                                      const std::filesystem::path& dataset_dir) {
  const std::string where = p.file.string();
  return {{"primary_A", p.a.primary_deg},
          {"secondary_A", p.a.secondary_deg},
          {"primary_B", p.b.primary_deg},
          {"secondary_B", p.b.secondary_deg},
          {"vessel_points_3d", pts.world},
          {"vessel_points_A", pts.a},
          {"vessel_points_B", pts.b},
          {"centerline_3d", pts.world},
          {"centerline_A", pts.a},
          {"centerline_B", pts.b},
          {"K1", matrix_to_json(p.a.camera.K())},
          {"K2", matrix_to_json(p.b.camera.K())},
          {"gimm",
           {{"source", std::filesystem::relative(p.file, dataset_dir).generic_string()},
            {"camera_model", to_string(p.a.camera.model())},
            {"points_3d", "world mm (LPS), not voxel indices"},
            {"P1", matrix_to_json(p.a.camera.P())},
            {"P2", matrix_to_json(p.b.camera.P())},
            {"F", json_field(p.labels, "F", where)},
            {"F_convention", "x_B^T F x_A = 0, pixels"},
            {"view_class_A", p.a.view_class},
            {"view_class_B", p.b.view_class},
            {"sparse", json_field(p.labels, "sparse", where)}}}};
}

/// Everything the export gathers over the patients before its last files.
struct RefTotals {
  nlohmann::json frames = nlohmann::json::array();
  nlohmann::json spacing = nlohmann::json::object();
  std::map<std::string, std::vector<std::string>> lists{{"train", {}}, {"val", {}}, {"test", {}}};
  std::size_t pairs = 0, scenes = 0;
};

/// One patient's images, masks, scene and dense labels; its frames and list entry in `totals`.
inline void export_ref_patient(const DatasetReader& reader, const RefPatient& patient,
                               const std::string& mwhere, const std::filesystem::path& out_dir,
                               RefTotals& totals) {
  using nlohmann::json;
  namespace rf = reference_format;
  const std::string pwhere = mwhere + " (patient '" + patient.id + "')";
  const std::vector<RefPair> pairs = read_ref_pairs(reader, patient, pwhere);
  if (pairs.empty()) return;  // the reference writes no scene for a patient without pairs
  json image_paths = json::array(), pair_infos = json::array(), dense_pairs = json::object();
  for (const RefPair& p : pairs) {
    const std::string name = rf::pair_name(p.a.system, p.a.view_name, p.b.view_name);
    const std::string file_a = rf::image_name(patient.token, name, 'A');
    const std::string file_b = rf::image_name(patient.token, name, 'B');
    for (const auto& [view, file] :
         {std::pair<const RefView*, std::string>{&p.a, file_a}, {&p.b, file_b}}) {
      const DatasetLayout& layout = reader.layout();
      write_png(out_dir / "images" / file,
                read_ref_image(layout.view_image(patient.id, view->file), view->camera, false));
      write_png(out_dir / "masks" / file,
                read_ref_image(layout.view_mask(patient.id, view->file), view->camera, true));
    }
    const RefPoints pts = ref_points(p);
    add_ref_frames(p, pts, patient.token, name, totals.frames);
    dense_pairs[rf::dense_key(p.a.system, p.a.view_name, p.b.view_name)] =
        ref_dense_entry(p, pts, reader.root());
    const std::size_t i = image_paths.size();
    image_paths.push_back(file_a);
    image_paths.push_back(file_b);
    pair_infos.push_back({json::array({i, i + 1}), 1.0, json::array({0.0, 0.0, 0.0, 0.0})});
  }
  const json empty(image_paths.size(), "");
  const std::string scene = rf::kScenePrefix + patient.token;
  write_json_file(out_dir / "npz_scenes" / (scene + ".json"),
                  {{"image_paths", image_paths},
                   {"depth_paths", empty},
                   {"intrinsics", empty},
                   {"poses", empty},
                   {"pair_infos", pair_infos}},
                  2);
  write_json_file(out_dir / "dense_labels" / (rf::kDensePrefix + patient.token + ".json"),
                  {{"sample_id", patient.id}, {"pairs", dense_pairs}}, -1);
  totals.spacing[patient.token] = {1.0, 1.0, 1.0};
  totals.lists[patient.split].push_back(scene);
  totals.pairs += pairs.size();
  ++totals.scenes;
}

/// The files over all patients: frames, spacing, split lists, black list, pairs per scene.
inline void write_ref_totals(RefTotals& totals, const std::filesystem::path& out_dir) {
  write_json_file(out_dir / "frame_export_old.json", totals.frames, -1);
  write_json_file(out_dir / "voxel_spacing_dict.json", totals.spacing, 2);
  for (auto& [split, names] : totals.lists) {
    std::sort(names.begin(), names.end());
    std::string text;
    for (const auto& s : names) text += s + "\n";
    write_file_atomic(out_dir / (split + "_list.txt"), text);
  }
  write_file_atomic(out_dir / "black_list.txt", std::string());
  write_file_atomic(out_dir / "npz_scenes" / "split_length.txt",
                    std::to_string(totals.scenes ? totals.pairs / totals.scenes : 0));
}

}  // namespace detail

/// Converts the finished gimm dataset in `dataset_dir` (manifest.json, patients/<id>/...)
/// into the reference layout under `out_dir` (see the file comment). Patients whose manifest
/// status is not "ok" are skipped, as the reference skips samples it could not process.
/// Existing files of the same names are replaced; nothing else in `out_dir` is touched. This
/// overload takes the dataset's manifest as given (`mwhere` names it in errors): a run exports
/// before it renames its manifest into place, so that the two appear together. The patients'
/// files are read through DatasetReader.
inline void export_reference(const std::filesystem::path& dataset_dir,
                             const nlohmann::json& manifest, const std::string& mwhere,
                             const std::filesystem::path& out_dir) {
  const std::vector<detail::RefPatient> patients = detail::exportable_patients(manifest, mwhere);
  const DatasetReader reader(dataset_dir);
  for (const char* sub : {"images", "masks", "npz_scenes", "dense_labels"})
    create_folders(out_dir / sub);
  detail::RefTotals totals;
  for (const detail::RefPatient& patient : patients)
    detail::export_ref_patient(reader, patient, mwhere, out_dir, totals);
  detail::write_ref_totals(totals, out_dir);
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
