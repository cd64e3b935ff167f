#pragma once
/// The DRR dataset pipeline: CT + coronary label -> angiograms, vessel masks, cameras and
/// dense 3D-2D pair labels, one patient at a time, resumable and shardable.
///
/// The files and their layout belong to the dataset room (dataset/layout.hpp, writer.hpp);
/// the run around this (resume, shards, merge) is pipeline/dataset_run.hpp.
/// Every file depends only on (parameters, seed, patient id). A patient is made
/// in a staging folder and renamed to patients/<id>/ when complete (done.json last), so a
/// patient's folder is there whole or not at all, whatever stops the run (a bad input, a full
/// disk, a kill); a finished patient is skipped on restart, and shards write disjoint patients
/// whose union is byte-identical to one run.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <future>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "gimm/anatomy/attenuation.hpp"
#include "gimm/anatomy/catheter.hpp"
#include "gimm/anatomy/components.hpp"
#include "gimm/anatomy/isocenter.hpp"
#include "gimm/anatomy/phantom.hpp"
#include "gimm/anatomy/skeleton.hpp"
#include "gimm/anatomy/tube_mesh.hpp"
#include "gimm/anatomy/vessel_mesh.hpp"
#include "gimm/core/hash.hpp"
#include "gimm/dataset/centerlines_json.hpp"
#include "gimm/dataset/formation_json.hpp"
#include "gimm/dataset/writer.hpp"
#include "gimm/geometry/carm.hpp"
#include "gimm/io/camera_json.hpp"
#include "gimm/io/files.hpp"
#include "gimm/io/png.hpp"
#include "gimm/io/volume_file.hpp"
#include "gimm/labels/correspondence.hpp"
#include "gimm/labels/view_list.hpp"
#include "gimm/labels/view_protocol.hpp"
#include "gimm/render/angiogram_formation.hpp"
#include "gimm/render/vessel_mesh_projector.hpp"
#include "gimm/render/view_renderer.hpp"
#include "gimm/version.hpp"

namespace gimm {

/// The angiography recipe's soft-tissue weight in formed views (system_renderer says why).
inline constexpr double kFormedSoftTissueWeight = 1.0;

struct DatasetOptions {
  std::uint64_t seed = 0;
  ViewMode view_mode = ViewMode::shared;
  /// Views placed on purpose (labels/view_list.hpp): when not empty they replace the protocol
  /// (view_mode is then ignored and recorded as "listed").
  std::vector<ListedPair> listed_views;
  CArm carm;  ///< detector, distances and model; angles come from the protocol
  ContrastPreset preset = ContrastPreset::angiography;  ///< the contrast recipe's preset
  /// Tissue beyond the scan's axial coverage (padded_attenuation.hpp, docs/recipes.md): 0 = air.
  double pad_mm = kDefaultPadMm;
  Projector projector = Projector::siddon;
  VesselMode vessel_mode = VesselMode::voxel;
  /// Phantoms only, with vessel_mode mesh: the surface is the phantom's analytic tubes
  /// (anatomy/tube_mesh.hpp) instead of its label's voxel surface, and the labelled
  /// centerlines are the same tubes' axes instead of the label's skeleton (`--vessels tubes`).
  bool phantom_tubes = false;
  /// Mesh modes: blur each view's background by half a voxel's footprint before the vessels
  /// are added (RendererOptions::smooth_voxel_steps; `--smooth-background`).
  bool smooth_voxel_steps = false;
  std::size_t sparse_count = 20;
  bool write_line_integrals = false;  ///< also each view's float32 line integrals (<view>.npy)
  /// Also each view as a C-arm forms it (render/angiogram_formation.hpp), a named stage after
  /// the render: <view>.formed.png and <view>.field.png, the drawn parameters in camera.json
  /// "formation". Every other file is the same as without it.
  bool form_angiogram = false;
  AngiogramFormationRanges formation_ranges;  ///< what form_angiogram draws each view from
  /// With form_angiogram, the injected lumen is iodine (render/iodine.hpp) instead of the
  /// recipe's fixed lumen_hu: one contrast drawn per patient and system from these ranges, so
  /// vessel contrast follows from the concentration and the beam's energy.
  IodineContrastRanges iodine_ranges;
  /// With form_angiogram, phantoms only: the share of systems imaged with their guiding
  /// catheter (anatomy/catheter.hpp), [0, 1], and the contrast it holds (undiluted, mgI/mL).
  double catheter_probability = 0.9;
  double catheter_iodine_mg_per_ml = 350;
  double split_train = 0.70, split_val = 0.15;  ///< the rest is test
  double min_spur_mm = 3.0;
  /// A label with one tree only: make the system it is assigned to (split_coronary_systems'
  /// allow_single, by the volume centre) and record the other as absent, instead of failing.
  bool allow_single_system = false;
  /// Log a warning for a patient whose label loses more than this share of its voxels to specks
  /// and components beyond the two largest. Only the log depends on it, so it is no parameter
  /// of the files (not in to_json()).
  double warn_dropped_fraction = 0.05;

  /// The detector and distances of every view (angles and isocentre are set per view).
  nlohmann::json carm_settings() const {
    return {{"model", to_string(carm.model)},
            {"image_size", {{"rows", carm.rows}, {"cols", carm.cols}}},
            {"sid_mm", carm.sid_mm},
            {"sod_mm", carm.sod_mm},
            {"pixel_mm", carm.pixel_mm},
            {"principal_point", matrix_to_json(carm.principal_point_or_centre())}};
  }

  nlohmann::json to_json() const {
    nlohmann::json j = {{"seed", seed},
                        {"view_mode", listed_views.empty() ? gimm::to_string(view_mode) : "listed"},
                        {"carm", carm_settings()},
                        {"recipe", gimm::to_string(preset)},
                        {"pad_mm", pad_mm},
                        {"projector", gimm::to_string(projector)},
                        {"vessel_mode", phantom_tubes ? "tubes" : gimm::to_string(vessel_mode)},
                        {"sparse_count", sparse_count},
                        {"line_integrals_npy", write_line_integrals},
                        {"split", {split_train, split_val, 1 - split_train - split_val}},
                        {"min_spur_mm", min_spur_mm},
                        {"allow_single_system", allow_single_system},
                        {"gimm_version", GIMM_VERSION_STRING}};
    if (!listed_views.empty()) j["views"] = view_list_to_json(listed_views);
    // Only when on (this and the formation): runs without it keep their records (and resume)
    // byte for byte.
    if (smooth_voxel_steps) j["smooth_voxel_steps"] = true;
    if (form_angiogram)
      j["formation"] = {
          {"stage", "angiogram"},
          {"soft_tissue_weight", kFormedSoftTissueWeight},
          {"ranges", gimm::to_json(formation_ranges)},
          {"iodine_ranges",
           {{"iodine_mg_per_ml",
             {iodine_ranges.iodine_mg_per_ml.lo, iodine_ranges.iodine_mg_per_ml.hi}},
            {"effective_kev", {iodine_ranges.effective_kev.lo, iodine_ranges.effective_kev.hi}}}},
          {"catheter",
           {{"probability", catheter_probability},
            {"iodine_mg_per_ml", catheter_iodine_mg_per_ml}}}};
    return j;
  }
};

/// One input patient: ImageCAS files, or a phantom seed.
struct PatientSource {
  std::string id;
  std::filesystem::path image, label;  ///< files (empty for a phantom)
  std::optional<std::uint64_t> phantom_seed;
  PhantomSize phantom_size = PhantomSize::small;
  TreeDetail phantom_tree = TreeDetail::classic;
  LumenOptions phantom_lumen;            ///< stenoses, irregular calibre (none: the smooth taper)
  TortuosityOptions phantom_tortuosity;  ///< an irregular course (none: the classic one)
  std::string split = "train";           ///< train | val | test (assign_splits)
};

/// The id of an ImageCAS-style image file, "<id>.img<ext>" with <ext> any ending gimm reads
/// (volume_extensions()), or empty when `file` is not one.
inline std::string imagecas_image_id(const std::filesystem::path& file) {
  const std::string name = file.filename().string(), ext = volume_extension(file), tag = ".img";
  if (ext.empty() || name.size() <= ext.size() + tag.size()) return {};
  const std::string stem = name.substr(0, name.size() - ext.size());
  if (stem.compare(stem.size() - tag.size(), tag.size(), tag) != 0) return {};
  return stem.substr(0, stem.size() - tag.size());
}

/// `count` phantom patients "phantom-0000", ... of run seed `seed` (patient n: phantom seed
/// seed * 1000003 + n).
inline std::vector<PatientSource> phantom_sources(int count, std::uint64_t seed, PhantomSize size,
                                                  TreeDetail tree = TreeDetail::classic) {
  GIMM_CHECK(count > 0, "phantom_sources: the patient count must be positive, got " << count);
  std::vector<PatientSource> sources;
  for (int n = 0; n < count; ++n) {
    PatientSource s;
    char id[32];
    std::snprintf(id, sizeof id, "phantom-%04d", n);
    s.id = id;
    s.phantom_seed = seed * 1000003ull + static_cast<std::uint64_t>(n);
    s.phantom_size = size;
    s.phantom_tree = tree;
    sources.push_back(s);
  }
  return sources;
}

/// The file-name patterns scan_imagecas_folder looks for, for messages.
inline std::string imagecas_patterns() {
  std::string out;
  for (const auto& ext : volume_extensions())
    out += (out.empty() ? "" : ", ") + ("<id>.img" + ext) + " with <id>.label" + ext;
  return out;
}

/// ImageCAS-style folder with its sub-folders (ImageCAS ships 1-200/, 201-400/, ...): every
/// <id>.img<ext> (imagecas_image_id) with its label <id>.label<ext> in the same folder, sorted
/// by id. Hidden files and folders (name starting with '.') are skipped. A missing label is kept
/// (the patient fails with a clear error in the manifest; the run goes on); an id found twice is
/// an error naming both files, as each id is one patients/<id>/ folder.
inline std::vector<PatientSource> scan_imagecas_folder(const std::filesystem::path& dir) {
  namespace fs = std::filesystem;
  GIMM_CHECK_AS(IoError, fs::is_directory(dir),
                "input folder '" << dir.string() << "' "
                                 << (fs::exists(dir) ? "is a file, not a folder of patients"
                                                     : "does not exist"));
  std::vector<PatientSource> out;
  for (auto it = fs::recursive_directory_iterator(dir); it != fs::recursive_directory_iterator();
       ++it) {
    const fs::path& path = it->path();
    if (path.filename().string().rfind('.', 0) == 0) {
      if (it->is_directory()) it.disable_recursion_pending();
      continue;
    }
    const std::string id = imagecas_image_id(path);
    if (id.empty() || !it->is_regular_file()) continue;
    PatientSource p;
    p.id = id;
    p.image = path;
    p.label = path.parent_path() / (id + ".label" + volume_extension(path));
    out.push_back(std::move(p));
  }
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) {
    return std::tie(a.id, a.image) < std::tie(b.id, b.image);
  });
  for (std::size_t k = 1; k < out.size(); ++k)
    GIMM_CHECK(out[k].id != out[k - 1].id,
               "input folder '" << dir.string() << "': patient id '" << out[k].id
                                << "' is there twice, as '" << out[k - 1].image.string()
                                << "' and '" << out[k].image.string()
                                << "'; ids must be unique (one patients/<id>/ folder each)");
  GIMM_CHECK(!out.empty(), "input folder '" << dir.string()
                                            << "' (sub-folders included) holds no patient: looked "
                                               "for "
                                            << imagecas_patterns());
  return out;
}

/// Patient-level split with exact proportions: the patients are ordered by a seeded hash of
/// their id; the first round(val n) go to val, the next round(test n) to test, the rest to train,
/// and with three or more patients val and test get at least one each. It depends on the seed
/// and the set of ids only, so every shard computes the same split.
inline void assign_splits(std::vector<PatientSource>& patients, const DatasetOptions& o) {
  const double test_fraction = 1 - o.split_train - o.split_val;
  GIMM_CHECK(o.split_train >= 0 && o.split_val >= 0 && test_fraction >= -1e-12,
             "split: fractions must be >= 0 and add up to at most 1, got train "
                 << o.split_train << ", val " << o.split_val);
  const std::size_t n = patients.size();
  std::vector<std::pair<std::uint64_t, std::size_t>> order(n);
  for (std::size_t k = 0; k < n; ++k)
    order[k] = {Rng(o.seed ^ stable_hash("split:" + patients[k].id)).next_u64(), k};
  std::sort(order.begin(), order.end());
  const auto share = [&](double fraction) {
    auto count = static_cast<std::size_t>(std::llround(fraction * static_cast<double>(n)));
    return n >= 3 && fraction > 0 ? std::max<std::size_t>(count, 1) : count;
  };
  const std::size_t n_val = share(o.split_val), n_test = std::min(n - n_val, share(test_fraction));
  for (std::size_t r = 0; r < n; ++r)
    patients[order[r].second].split = r < n_val ? "val" : (r < n_val + n_test ? "test" : "train");
}

/// What a patient's files depend on: the run's parameters and the patient's own input. Kept in
/// done.json, so that resuming into a folder made with other parameters is refused.
inline nlohmann::json patient_run(const PatientSource& src, const DatasetOptions& o) {
  nlohmann::json input;
  if (src.phantom_seed) {
    input = {{"phantom_seed", *src.phantom_seed}, {"phantom_size", to_string(src.phantom_size)}};
    // Only when rich: a classic run's record (and its resumption) is as it always was.
    if (src.phantom_tree != TreeDetail::classic)
      input["phantom_tree"] = to_string(src.phantom_tree);
    if (!src.phantom_lumen.none())
      input["phantom_lumen"] = {{"stenoses", src.phantom_lumen.stenoses},
                                {"irregularity", src.phantom_lumen.irregularity},
                                {"irregularity_mm", src.phantom_lumen.irregularity_mm}};
    if (!src.phantom_tortuosity.none())
      input["phantom_tortuosity"] = tortuosity_json(src.phantom_tortuosity);
  } else
    input = {{"image", src.image.filename().string()}, {"label", src.label.filename().string()}};
  return {{"parameters", o.to_json()}, {"input", input}, {"split", src.split}};
}

namespace detail {

/// Seconds since the last lap (or since construction).
class Stopwatch {
 public:
  double lap() {
    const auto now = std::chrono::steady_clock::now();
    const double seconds = std::chrono::duration<double>(now - last_).count();
    last_ = now;
    return seconds;
  }

 private:
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};
}  // namespace detail

/// Wall-clock seconds of one patient's stages (summed over both systems). They vary run to run,
/// so they go to the log (and gimm-dataset --timings FILE, outside the dataset), never into it.
struct PatientTimings {
  double read = 0;         ///< CT and label files (or building the phantom), grid check
  double split = 0;        ///< connected components, LCA/RCA split
  double centerlines = 0;  ///< distance transform, thinning, pruning
  double attenuation = 0;  ///< dense tissue; voxel mode: the renderer (attenuation, vessel box)
  double mesh = 0;         ///< mesh mode: the renderer (attenuation, vessel surface, lumen gain)
  double views = 0;        ///< view loops: renders, masks, waiting for the view files
  double pairs = 0;        ///< pair labels
  double writes = 0;       ///< view files (helper thread, during views), pair files, centerlines
  double total = 0;        ///< the whole patient; less than the sum, as writes overlap views
  std::size_t view_count = 0;

  /// (stage, seconds) in pipeline order.
  std::vector<std::pair<const char*, double>> stages() const {
    return {{"read", read},
            {"split", split},
            {"centerlines", centerlines},
            {"attenuation", attenuation},
            {"mesh", mesh},
            {"views", views},
            {"pairs", pairs},
            {"writes", writes}};
  }

  PatientTimings& operator+=(const PatientTimings& o) {
    read += o.read;
    split += o.split;
    centerlines += o.centerlines;
    attenuation += o.attenuation;
    mesh += o.mesh;
    views += o.views;
    pairs += o.pairs;
    writes += o.writes;
    total += o.total;
    view_count += o.view_count;
    return *this;
  }

  nlohmann::json to_json() const {
    nlohmann::json seconds = {{"total", total}};
    for (const auto& [stage, s] : stages()) seconds[stage] = s;
    return {{"seconds", seconds},
            {"views", view_count},
            {"seconds_per_view", view_count ? views / static_cast<double>(view_count) : 0.0}};
  }

  /// "12.30 s: read 1.20, split 0.30, ..." for the log.
  std::string summary() const {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.2f s:", total);
    std::string out = buf;
    for (const auto& [stage, s] : stages()) {
      std::snprintf(buf, sizeof buf, " %s %.2f,", stage, s);
      out += buf;
    }
    out.pop_back();
    if (view_count) {
      std::snprintf(buf, sizeof buf, " (%zu views, %.3f s per view)", view_count,
                    views / static_cast<double>(view_count));
      out += buf;
    }
    return out;
  }
};

/// The log's warning for a patient record whose label lost more than o.warn_dropped_fraction of
/// its voxels in the split, or empty.
inline std::string dropped_voxels_warning(const nlohmann::json& record, const DatasetOptions& o) {
  const nlohmann::json label = record.value("label", nlohmann::json::object());
  const double fraction = label.value("dropped_fraction", 0.0);
  if (!(fraction > o.warn_dropped_fraction)) return {};
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "patient %s: %.1f%% of the label's voxels (%lld of %lld, in %d of its %d "
                "components) are in neither LCA nor RCA and are not rendered: the split keeps "
                "the two largest components (warning threshold %g%%)",
                record.value("id", std::string("?")).c_str(), 100 * fraction,
                label.value("dropped_voxels", 0LL), label.value("voxels", 0LL),
                label.value("dropped_components", 0), label.value("components", 0),
                100 * o.warn_dropped_fraction);
  return buf;
}

/// The random stream of one purpose and item of a patient ("views:LCA", "sparse:LCA_00_03"):
/// each drawn on its own, so a change to one view or pair moves nothing else.
inline Rng patient_stream(const DatasetOptions& o, const std::string& patient,
                          const std::string& purpose) {
  return Rng(o.seed).fork(stable_hash(patient + "/" + purpose));
}

/// A patient's CT (HU) and coronary label, on one grid.
struct PatientVolumes {
  Volume<float> hu;
  Volume<std::uint8_t> label;
  std::optional<CenterlineTree> tubes;    ///< a phantom's analytic tree (its label's source)
  std::optional<PhantomAnatomy> anatomy;  ///< a phantom's seeded anatomy (its aorta, ...)
};

/// Step 1: the phantom built from its seed, or the CT and label files read and their grids
/// checked against each other.
inline PatientVolumes read_patient(const PatientSource& src) {
  if (src.phantom_seed) {
    PhantomOptions po;
    po.seed = *src.phantom_seed;
    po.size = src.phantom_size;
    po.tree = src.phantom_tree;
    po.lumen = src.phantom_lumen;
    po.tortuosity = src.phantom_tortuosity;
    Phantom p = make_phantom(po);
    return {volume_cast<float>(p.hu), std::move(p.label), std::move(p.centerlines),
            std::move(p.anatomy)};
  }
  GIMM_CHECK_AS(IoError, std::filesystem::exists(src.label),
                "patient " << src.id << ": label '" << src.label.string() << "' is missing");
  PatientVolumes v{read_volume<float>(src.image), read_volume<std::uint8_t>(src.label),
                   std::nullopt, std::nullopt};
  check_same_grid(v.hu.geometry(), v.label.geometry(), "patient " + src.id);
  return v;
}

/// `--vessels tubes`: one system's branches of the phantom's analytic tree, as tube_axes (the
/// labelled centerlines), and their tube surface (set in `surface`).
inline CenterlineTree system_tubes(const PatientVolumes& patient, CoronarySystem system,
                                   const std::string& id,
                                   std::shared_ptr<const VesselSurface>& surface) {
  GIMM_CHECK(patient.tubes, "patient " << id
                                       << ": tube vessels (DatasetOptions::phantom_tubes) need a "
                                          "phantom patient (its analytic tree); a CT's vessels "
                                          "are its label (voxel or mesh)");
  CenterlineTree tree;
  std::vector<int> index(patient.tubes->branches.size(), -1);
  for (std::size_t b = 0; b < patient.tubes->branches.size(); ++b) {
    CenterlineBranch br = patient.tubes->branches[b];
    if (br.system != system) continue;
    br.parent = br.parent >= 0 ? index[br.parent] : -1;
    index[b] = static_cast<int>(tree.branches.size());
    tree.branches.push_back(std::move(br));
  }
  tree = tube_axes(tree);  // this system only: axes are per branch
  surface = std::make_shared<const VesselMeshProjector>(tube_mesh(tree, system));
  return tree;
}

/// The renderer of one system's views: its injection (voxel mode) or its vessel surface (mesh
/// mode) over the patient's attenuation, with the patient's dense-tissue classes.
/// `iodine`: the injection's contrast when the lumen is iodine (form_angiogram), else the
/// recipe's fixed lumen_hu.
inline ViewRenderer system_renderer(const Volume<float>& hu, const Volume<std::uint8_t>& mask,
                                    const DatasetOptions& o, const std::string& patient,
                                    const DenseTissue* dense,
                                    const IodineContrast* iodine = nullptr,
                                    std::shared_ptr<const VesselSurface> tubes = nullptr) {
  RendererOptions ro;
  ro.recipe.preset = o.preset;
  if (iodine) {
    ro.recipe.lumen_hu = iodine->lumen_hu();
    // A formed view is physics: soft tissue attenuates in full. The recipe's soft_weight (0.35)
    // stands in for the range compression and window of a clinical system, which the
    // formation applies itself; kept, it would make bone 3x denser than soft tissue.
    ro.recipe.soft_weight = kFormedSoftTissueWeight;
  }
  ro.pad_mm = o.pad_mm;
  ro.projector = o.projector;
  ro.vessels = o.vessel_mode;
  ro.smooth_voxel_steps = o.smooth_voxel_steps;
  if (o.vessel_mode == VesselMode::mesh && !tubes) tubes = vessel_surface_from_mask(mask);
  return ViewRenderer(hu, &mask, ro, "patient " + patient, dense, std::move(tubes));
}

/// The camera record of one view: the C-arm, its view class and the injected system.
inline nlohmann::json view_camera_json(const CArm& carm, const SampledView& view,
                                       CoronarySystem system) {
  nlohmann::json j = to_json(carm);
  j["view_class"] = view.view_class;
  j["view_name"] = view_class(view.view_class).name;
  j["system"] = to_string(system);
  return j;
}

/// The image-formation stage of a system's views: the ranges each view's formation is drawn
/// from, and the system's stream (view v draws from stream.fork(v): the views' formations are
/// independent of each other and of every other random choice of the patient).
struct ViewFormationStage {
  ViewFormationStage(AngiogramFormationRanges r, Rng s, IodineContrast i)
      : ranges(std::move(r)), stream(s), iodine(i) {}
  AngiogramFormationRanges ranges;
  Rng stream;
  IodineContrast iodine;  ///< the system's injection, recorded with each view
  /// The system's guiding catheter, when imaged: its surface, the attenuation its contrast
  /// adds over the blood it displaces (mm^-1), and its record for each view.
  std::shared_ptr<const VesselSurface> catheter;
  double catheter_mu_per_mm = 0;
  nlohmann::json catheter_record = {{"present", false}};
};

/// The system's catheter for `stage` (phantoms with form_angiogram): present with
/// o.catheter_probability, from the stream "catheter:<SYS>".
inline void add_catheter(ViewFormationStage& stage, const PatientVolumes& patient,
                         CoronarySystem system, const DatasetOptions& o, const std::string& id) {
  GIMM_CHECK(std::isfinite(o.catheter_probability) && o.catheter_probability >= 0 &&
                 o.catheter_probability <= 1,
             "dataset: catheter_probability must be in [0, 1], got " << o.catheter_probability);
  if (!patient.anatomy || !patient.tubes) return;  // a CT: no catheter is modelled
  Rng rng = patient_stream(o, id, std::string("catheter:") + to_string(system));
  if (rng.uniform() >= o.catheter_probability) return;
  CatheterOptions co;
  CenterlineTree one;
  one.branches.push_back(guiding_catheter(*patient.anatomy, *patient.tubes, system, rng, co));
  stage.catheter = std::make_shared<const VesselMeshProjector>(tube_mesh(one, system));
  const IodineContrast column{o.catheter_iodine_mg_per_ml, stage.iodine.effective_kev};
  stage.catheter_mu_per_mm = column.lumen_mu_per_mm() - column.blood_mu_per_mm();
  stage.catheter_record = {{"present", true},
                           {"lumen_radius_mm", co.lumen_radius_mm},
                           {"iodine_mg_per_ml", o.catheter_iodine_mg_per_ml},
                           {"mu_per_mm", stage.catheter_mu_per_mm}};
}

/// A view's line integrals with the stage's catheter added (its chord times its attenuation):
/// imaged, not labelled, so masks and points stay the vessels' alone.
inline Image<float> with_catheter(Image<float> line_integrals, const ViewFormationStage& stage,
                                  const Camerad& camera) {
  if (!stage.catheter) return line_integrals;
  const VesselProjection catheter = stage.catheter->project(camera);
  for (std::size_t p = 0; p < line_integrals.size(); ++p)
    line_integrals.data()[p] +=
        static_cast<float>(stage.catheter_mu_per_mm * catheter.chord_mm.data()[p]);
  return line_integrals;
}

/// The formation stage of one view: its drawn parameters go to the camera record `cj`, the
/// formed image and field mask are returned.
inline FormedAngiogram form_view(const RenderedView& view, const CArm& carm,
                                 const ViewFormationStage& stage, std::size_t v,
                                 nlohmann::json& cj) {
  GIMM_CHECK(stage.ranges.bits == 8 || stage.ranges.bits == 16,
             "image formation: the dataset writes 8- or 16-bit formed PNGs, got bits "
                 << stage.ranges.bits);
  Rng rng = stage.stream.fork(v);
  const AngiogramFormation f = randomize(stage.ranges, rng);
  FormedAngiogram formed = form_angiogram(with_catheter(view.line_integrals, stage, carm.camera()),
                                          carm.pixel_mm, f, rng);
  cj["formation"] = to_json(f);
  cj["formation"]["iodine"] = to_json(stage.iodine);
  cj["formation"]["iodine"]["lumen_hu"] = stage.iodine.lumen_hu();
  cj["formation"]["catheter"] = stage.catheter_record;
  cj["formation"]["png"] =
      "formed.png: display = value / (2^bits - 1), bright background, "
      "dark vessels; field.png: 255 = exposed";
  return formed;
}

/// The rendered and labelled views of one system.
struct SystemViews {
  std::vector<Camerad> cameras;
  std::vector<std::vector<ProjectedPoint>> projected;  ///< per view, one per label point
  std::vector<std::string> names;
};

/// Step: renders, labels and writes every view of `plan`. A view's outputs (Beer-Lambert and
/// 16-bit scaling, labels, PNGs, JSON: serial work) are written on a helper thread while the
/// next view renders on every core; one view in flight at a time. The helper adds its time to
/// t.writes (one task at a time, each started after the previous one returned).
inline SystemViews render_system_views(const ViewRenderer& renderer, const ViewPlan& plan,
                                       const CArm& settings, const Eigen::Vector3d& isocenter,
                                       const std::vector<LabelPoint>& points,
                                       const DatasetWriter& writer, const std::string& patient,
                                       bool write_line_integrals, PatientTimings& t,
                                       const ViewFormationStage* formation = nullptr) {
  SystemViews out;
  const bool mesh_mode = renderer.options().vessels == VesselMode::mesh;
  // Declared after everything the task reads, so an exception here waits for it first.
  std::future<std::vector<ProjectedPoint>> in_flight;
  const auto collect = [&] {
    if (in_flight.valid()) out.projected.push_back(in_flight.get());
  };
  for (std::size_t v = 0; v < plan.views.size(); ++v) {
    CArm carm = settings;
    carm.primary_deg = plan.views[v].primary_deg;
    carm.secondary_deg = plan.views[v].secondary_deg;
    carm.isocenter = isocenter;
    const Camerad camera = carm.camera();
    const std::string name = view_name(to_string(plan.system), v);
    RenderedView view = renderer.render(camera);
    nlohmann::json cj = view_camera_json(carm, plan.views[v], plan.system);
    collect();
    in_flight = std::async(std::launch::async, [&, view = std::move(view), cj = std::move(cj),
                                                camera, name, carm, v]() mutable {
      detail::Stopwatch writing;
      auto labels =
          label_view(points, camera, &view.vessel_mask, mesh_mode ? &view.overlap : nullptr);
      mark_occlusion(labels, points,
                     [&](const Eigen::Vector3d& X) { return renderer.unoccluded(camera, X); });
      IntensityWindow window;
      Image<std::uint16_t> image = to_uint16_min_max(view.intensity(), &window);
      cj["intensity_window"] = intensity_window_json(window.lo, window.hi);
      FormedAngiogram formed;
      if (formation) formed = form_view(view, carm, *formation, v, cj);
      ViewFiles files{std::move(image),
                      std::move(view.vessel_mask),
                      mesh_mode ? &view.overlap : nullptr,
                      write_line_integrals ? &view.line_integrals : nullptr,
                      formation ? &formed.quantised : nullptr,
                      formation ? formation->ranges.bits : 8,
                      formation ? &formed.field_mask : nullptr,
                      std::move(cj),
                      view_points_json(points, labels)};
      writer.write_view(patient, name, std::move(files));
      t.writes += writing.lap();
      return labels;
    });
    out.cameras.push_back(camera);
    out.names.push_back(name);
  }
  collect();
  return out;
}

/// Step: labels and writes every pair of `plan` (sparse points from the pair's own stream);
/// returns the number of dense labels.
inline std::size_t label_system_pairs(const ViewPlan& plan, const SystemViews& views,
                                      const std::vector<LabelPoint>& points,
                                      const DatasetOptions& o, const DatasetWriter& writer,
                                      const std::string& patient, PatientTimings& t) {
  std::size_t dense_total = 0;
  detail::Stopwatch stage;
  for (const auto& pr : plan.pairs) {
    const std::string name = pair_name(to_string(plan.system), pr.a, pr.b);
    Rng sparse_stream = patient_stream(o, patient, "sparse:" + name);
    const PairLabels labels =
        label_pair(points, views.projected[pr.a], views.projected[pr.b], views.cameras[pr.a],
                   views.cameras[pr.b], o.sparse_count, sparse_stream);
    dense_total += labels.dense.size();
    t.pairs += stage.lap();
    writer.write_pair(patient, name,
                      pair_json(labels, plan.views[pr.a], plan.views[pr.b], views.names[pr.a],
                                views.names[pr.b]));
    t.writes += stage.lap();
  }
  return dense_total;
}

/// The views and pairs of one system: the listed ones (DatasetOptions::listed_views), else the
/// protocol's, drawn from the patient's own stream for that system.
inline ViewPlan system_plan(CoronarySystem system, const DatasetOptions& o,
                            const std::string& patient) {
  if (!o.listed_views.empty()) return plan_listed_views(system, o.listed_views);
  Rng view_stream = patient_stream(o, patient, std::string("views:") + to_string(system));
  return plan_views(system, o.view_mode, view_stream);
}

/// The record of one system of a patient (done.json, the manifest).
inline nlohmann::json system_record(std::int64_t voxels, const ViewPlan& plan, double centerline_mm,
                                    std::size_t dense_labels) {
  return {{"present", true},
          {"voxels", voxels},
          {"views", plan.views.size()},
          {"pairs", plan.pairs.size()},
          {"centerline_mm", centerline_mm},
          {"dense_labels", dense_labels}};
}

/// The record of a system the label does not have (allow_single_system).
inline nlohmann::json absent_system_record() {
  return {{"present", false}, {"voxels", 0},          {"views", 0},
          {"pairs", 0},       {"centerline_mm", 0.0}, {"dense_labels", 0}};
}

namespace detail {

/// One coronary system of a patient (generate_patient): its centerlines (appended to `all`, whose
/// branch indices the labels use), views and pair labels, written by `writer`; returns the
/// system's record. A system the label does not have (allow_single_system) gets none of them.
inline nlohmann::json generate_system(CoronarySystem system, const Volume<std::uint8_t>& mask,
                                      std::int64_t voxels, const PatientVolumes& patient,
                                      const PatientSource& src, const DatasetOptions& o,
                                      const DenseTissue* dense, const DatasetWriter& writer,
                                      CenterlineTree& all, PatientTimings& t, Stopwatch& stage) {
  if (voxels == 0) return absent_system_record();
  stage.lap();
  SkeletonOptions so;
  so.system = system;
  so.min_spur_mm = o.min_spur_mm;
  std::shared_ptr<const VesselSurface> tubes;
  const CenterlineTree tree = o.phantom_tubes ? system_tubes(patient, system, src.id, tubes)
                                              : extract_centerlines(mask, so, "patient " + src.id);
  all.append(tree);
  // Branch indices in the labels refer to centerlines.json (both systems).
  const auto points = flatten_centerlines(all, system);
  t.centerlines += stage.lap();
  const ViewPlan plan = system_plan(system, o, src.id);
  if (plan.views.empty())  // a view list that names the other system only
    return system_record(voxels, plan, tree.length(), 0);
  std::optional<IodineContrast> iodine;
  if (o.form_angiogram) {
    Rng rng = patient_stream(o, src.id, std::string("iodine:") + to_string(system));
    iodine = randomize(o.iodine_ranges, rng);
  }
  const ViewRenderer renderer = system_renderer(patient.hu, mask, o, src.id, dense,
                                                iodine ? &*iodine : nullptr, std::move(tubes));
  (o.vessel_mode == VesselMode::mesh ? t.mesh : t.attenuation) += stage.lap();
  std::optional<ViewFormationStage> formation;
  if (o.form_angiogram) {
    formation.emplace(o.formation_ranges,
                      patient_stream(o, src.id, std::string("formation:") + to_string(system)),
                      *iodine);
    add_catheter(*formation, patient, system, o, src.id);
  }
  const SystemViews views = render_system_views(
      renderer, plan, o.carm, vessel_isocenter(mask, "patient " + src.id), points, writer, src.id,
      o.write_line_integrals, t, formation ? &*formation : nullptr);
  t.views += stage.lap();
  t.view_count += plan.views.size();
  const std::size_t dense_total = label_system_pairs(plan, views, points, o, writer, src.id, t);
  stage.lap();
  return system_record(voxels, plan, tree.length(), dense_total);
}

}  // namespace detail

/// Generates one patient into out/patients/<id>/ and returns its record (also written as
/// done.json, last, with "run" added). The stage timings go to `timings` when given, never into
/// the dataset (they vary run to run; the dataset is byte-reproducible). Throws on bad input (the
/// caller records the error) and WriteError when a file cannot be written. The files are made in
/// patients/<id>.tmp.<host>.<pid>/ and that folder replaces patients/<id>/ (an unfinished one a
/// killed run left) when complete; on any error it is removed, and patients/<id>/ is left as it
/// was. The data flow of shared/docs/design.md, one named step per arrow.
inline nlohmann::json generate_patient(const PatientSource& src, const DatasetOptions& o,
                                       const std::filesystem::path& out,
                                       PatientTimings* timings = nullptr) {
  PatientTimings t;
  detail::Stopwatch whole;
  detail::Stopwatch stage;
  const PatientVolumes patient = read_patient(src);
  t.read = stage.lap();
  SplitOptions split_options;
  split_options.allow_single = o.allow_single_system;
  const auto split =
      split_coronary_systems(patient.label, split_options, "patient " + src.id + " label");
  t.split = stage.lap();
  const DatasetLayout layout(out);
  StagedFolder staged(layout.patient_dir(src.id), StagedFolder::Commit::replace);
  const DatasetWriter writer(layout.with_patient_suffix(temporary_suffix()));
  GIMM_ASSERT(writer.layout().patient_dir(src.id) == staged.dir());
  writer.create_patient(src.id);

  nlohmann::json record = {{"id", src.id},
                           {"split", src.split},
                           {"label", label_json(split)},
                           {"systems", nlohmann::json::object()}};
  if (src.phantom_seed) record["phantom_seed"] = *src.phantom_seed;
  // Bone or contrast (the angiography recipe's structure), found once for both systems.
  std::optional<DenseTissue> dense;
  if (o.preset == ContrastPreset::angiography) {
    ContrastRecipe recipe;
    recipe.preset = o.preset;
    dense = classify_dense_tissue(patient.hu, recipe);
  }
  t.attenuation += stage.lap();
  CenterlineTree all;
  for (const CoronarySystem system : {CoronarySystem::RCA, CoronarySystem::LCA}) {
    const bool lca = system == CoronarySystem::LCA;
    record["systems"][to_string(system)] = detail::generate_system(
        system, lca ? split.lca : split.rca, lca ? split.lca_voxels : split.rca_voxels, patient,
        src, o, dense ? &*dense : nullptr, writer, all, t, stage);
  }
  stage.lap();
  nlohmann::json centerlines = to_json(all);
  if (!src.phantom_lumen.none() && patient.anatomy)  // where the phantom's lumen narrows
    centerlines["phantom_lumen"] = lumen_json(src.phantom_lumen, patient.anatomy->stenoses);
  if (!src.phantom_tortuosity.none() && patient.anatomy)
    centerlines["phantom_tortuosity"] = tortuosity_json(src.phantom_tortuosity);
  writer.write_centerlines(src.id, centerlines);
  t.writes += stage.lap();
  record["status"] = "ok";
  t.total = whole.lap();
  nlohmann::json stored = record;
  stored["run"] = patient_run(src, o);
  writer.write_done_record(src.id, stored);
  // Another process running the same shard (a requeued job beside its predecessor) may have
  // finished this patient meanwhile: its complete folder stays, and this copy is dropped.
  if (!std::filesystem::exists(layout.done_record(src.id))) staged.commit();
  if (timings) *timings = t;
  return record;
}

}  // namespace gimm
