#pragma once
/// The DRR dataset pipeline: CT + coronary label -> angiograms, vessel masks, cameras and
/// dense 3D-2D pair labels, one patient at a time, resumable and shardable.
///
/// Layout under the output directory (docs/dataset.md):
///   patients/<id>/centerlines.json            centerlines extracted from the label
///   patients/<id>/views/<SYS>_<nn>.png        16-bit angiogram (Beer-Lambert, min-max)
///   patients/<id>/views/<SYS>_<nn>.mask.png   8-bit projected vessel mask (0/255)
///   patients/<id>/views/<SYS>_<nn>.overlap.png 8-bit vessel passages per pixel (mesh mode)
///   patients/<id>/views/<SYS>_<nn>.camera.json camera, view class, angles
///   patients/<id>/pairs/<SYS>_<nn>-<mm>.json  pair labels (dense, sparse, F, view classes)
///   patients/<id>/done.json                   the patient's record, written last
///   manifest.json (or manifest.shard-I-of-N.json), splits/{train,val,test}.txt
/// Every file is written atomically and depends only on (parameters, seed, patient id), so a
/// patient whose done.json exists is complete and is skipped on restart, and shards write
/// disjoint patients whose union is byte-identical to one run.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <future>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "gimm/anatomy/attenuation.hpp"
#include "gimm/anatomy/components.hpp"
#include "gimm/anatomy/phantom.hpp"
#include "gimm/anatomy/skeleton.hpp"
#include "gimm/anatomy/vessel_mesh.hpp"
#include "gimm/geometry/carm.hpp"
#include "gimm/io/camera_json.hpp"
#include "gimm/io/centerlines_json.hpp"
#include "gimm/io/files.hpp"
#include "gimm/io/nifti.hpp"
#include "gimm/io/png.hpp"
#include "gimm/labels/correspondence.hpp"
#include "gimm/labels/protocol.hpp"
#include "gimm/render/drr.hpp"
#include "gimm/render/vessel_mesh_projector.hpp"
#include "gimm/version.hpp"

namespace gimm {

/// Where the injected vessels' image comes from. voxel: the label's voxels carry the lumen
/// attenuation (as the reference does; staircase edges). mesh: the background is rendered
/// without injection and the lumen is added as exact chord length through the smoothed vessel
/// surface (Embree), anti-aliased; the 2D mask and the overlap count come from the same mesh.
enum class VesselMode { voxel, mesh };

inline VesselMode parse_vessel_mode(const std::string& s) {
  if (s == "voxel") return VesselMode::voxel;
  if (s == "mesh") return VesselMode::mesh;
  GIMM_FAIL("vessel mode must be voxel|mesh, got '" << s << "'");
}
inline const char* to_string(VesselMode m) {
  return m == VesselMode::mesh ? "mesh" : "voxel";
}

struct DatasetOptions {
  std::uint64_t seed = 0;
  ViewMode view_mode = ViewMode::shared;
  CArm carm;  ///< detector, distances and model; angles come from the protocol
  ContrastPreset recipe = ContrastPreset::angiography;
  Projector projector = Projector::siddon;
  VesselMode vessel_mode = VesselMode::voxel;
  std::size_t sparse_count = 20;
  double split_train = 0.70, split_val = 0.15;  ///< the rest is test
  double min_spur_mm = 3.0;

  /// The detector and distances (angles and isocentre are set per view).
  nlohmann::json carm_settings() const {
    nlohmann::json j = gimm::to_json(carm);
    for (const char* per_view :
         {"P", "K", "R", "t", "center", "primary_deg", "secondary_deg", "isocenter"})
      j.erase(per_view);
    return j;
  }

  nlohmann::json to_json() const {
    return {{"seed", seed},
            {"view_mode", gimm::to_string(view_mode)},
            {"carm", carm_settings()},
            {"recipe", gimm::to_string(recipe)},
            {"projector", gimm::to_string(projector)},
            {"vessel_mode", gimm::to_string(vessel_mode)},
            {"sparse_count", sparse_count},
            {"split", {split_train, split_val, 1 - split_train - split_val}},
            {"min_spur_mm", min_spur_mm},
            {"gimm_version", GIMM_VERSION_STRING}};
  }
};

/// One input patient: ImageCAS files, or a phantom seed.
struct PatientSource {
  std::string id;
  std::filesystem::path image, label;  ///< files (empty for a phantom)
  std::optional<std::uint64_t> phantom_seed;
  PhantomSize phantom_size = PhantomSize::small;
  std::string split = "train";  ///< train | val | test (assign_splits)
};

/// ImageCAS-style folder: every N.img.nii.gz with its N.label.nii.gz, sorted by id. A missing
/// label is kept (the patient fails with a clear error in the manifest; the run goes on).
inline std::vector<PatientSource> scan_imagecas_folder(const std::filesystem::path& dir) {
  GIMM_CHECK_AS(IoError, std::filesystem::is_directory(dir),
                "input folder '" << dir.string() << "' does not exist");
  std::vector<PatientSource> out;
  const std::string suffix = ".img.nii.gz";
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    if (name.size() <= suffix.size() ||
        name.compare(name.size() - suffix.size(), suffix.size(), suffix) != 0)
      continue;
    PatientSource p;
    p.id = name.substr(0, name.size() - suffix.size());
    p.image = entry.path();
    p.label = dir / (p.id + ".label.nii.gz");
    out.push_back(p);
  }
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.id < b.id; });
  GIMM_CHECK(!out.empty(), "input folder '" << dir.string() << "' holds no *.img.nii.gz");
  return out;
}

/// A stable 64-bit hash (FNV-1a) of a patient id: per-patient random streams do not depend on
/// the order, the shard or the machine.
inline std::uint64_t stable_hash(const std::string& s) {
  std::uint64_t h = 0xcbf29ce484222325ull;
  for (const unsigned char c : s) h = (h ^ c) * 0x100000001b3ull;
  return h;
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
  if (src.phantom_seed)
    input = {{"phantom_seed", *src.phantom_seed}, {"phantom_size", to_string(src.phantom_size)}};
  else
    input = {{"image", src.image.filename().string()}, {"label", src.label.filename().string()}};
  return {{"parameters", o.to_json()}, {"input", input}, {"split", src.split}};
}

namespace detail {

inline std::string two_digits(std::size_t n) {
  return (n < 10 ? "0" : "") + std::to_string(n);
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
          {"F", gimm::detail::matrix_to_json(labels.F)},
          {"F_convention", "x_b^T F x_a = 0, pixels"},
          {"dense_fields",
           {"u_a", "v_a", "u_b", "v_b", "x_mm", "y_mm", "z_mm", "branch", "point", "radius_mm"}},
          {"dense", dense},
          {"sparse", labels.sparse}};
}

/// Writes one view's files (`stem` + .png: the 16-bit angiogram; .mask.png; .overlap.png in
/// mesh mode; .camera.json; .points.json) and returns its projected points. `overlap` and
/// `mesh` are given in mesh mode only: the overlap map, and the projector that marks points
/// hidden behind another vessel.
inline std::vector<ProjectedPoint> write_view(
    const std::filesystem::path& stem, const Image<float>& integrals, Image<std::uint8_t> vessel,
    const Image<std::uint8_t>* overlap, const nlohmann::json& camera_json, const Camerad& camera,
    const std::vector<LabelPoint>& points, const VesselMeshProjector* mesh) {
  const auto file = [&](const char* suffix) { return stem.string() + suffix; };
  write_png(file(".png"), to_uint16_min_max(beer_lambert(integrals)));
  auto view = label_view(points, camera, &vessel, overlap);
  if (mesh)
    for (std::size_t n = 0; n < points.size(); ++n)
      if (view[n].in_image) view[n].visible = mesh->unoccluded(camera, points[n].world);
  for (auto& px : vessel.storage()) px = px ? 255 : 0;
  write_png(file(".mask.png"), vessel);
  if (overlap) write_png(file(".overlap.png"), *overlap);
  write_json_file(file(".camera.json"), camera_json);
  write_json_file(file(".points.json"), view_points_json(points, view), -1);
  return view;
}
}  // namespace detail

/// Generates one patient into out/patients/<id>/ and returns its record (also written as
/// done.json, last, without the timings "seconds" and "view_seconds"). Throws on bad input; the
/// caller records the error.
inline nlohmann::json generate_patient(const PatientSource& src, const DatasetOptions& o,
                                       const std::filesystem::path& out) {
  namespace fs = std::filesystem;
  const auto t0 = std::chrono::steady_clock::now();
  Volume<float> hu;
  Volume<std::uint8_t> label;
  if (src.phantom_seed) {
    PhantomOptions po;
    po.seed = *src.phantom_seed;
    po.size = src.phantom_size;
    Phantom p = make_phantom(po);
    hu = volume_cast<float>(p.hu);
    label = std::move(p.label);
  } else {
    GIMM_CHECK_AS(IoError, fs::exists(src.label),
                  "patient " << src.id << ": label '" << src.label.string() << "' is missing");
    hu = read_nifti<float>(src.image);
    label = read_nifti<std::uint8_t>(src.label);
    const std::string difference = grid_difference(hu.geometry(), label.geometry());
    GIMM_CHECK(difference.empty(),
               "patient " << src.id << ": image and label grids disagree: " << difference);
  }
  const auto split = split_coronary_systems(label, {}, "patient " + src.id + " label");
  const fs::path dir = out / "patients" / src.id;
  fs::create_directories(dir / "views");
  fs::create_directories(dir / "pairs");

  Rng rng = Rng(o.seed).fork(stable_hash(src.id));
  nlohmann::json record = {
      {"id", src.id}, {"split", src.split}, {"systems", nlohmann::json::object()}};
  if (src.phantom_seed) record["phantom_seed"] = *src.phantom_seed;
  double view_seconds = 0;  // the view loops: renders, masks and the writes they wait for
  CenterlineTree all;
  for (const CoronarySystem system : {CoronarySystem::RCA, CoronarySystem::LCA}) {
    const Volume<std::uint8_t>& mask = system == CoronarySystem::LCA ? split.lca : split.rca;
    SkeletonOptions so;
    so.system = system;
    so.min_spur_mm = o.min_spur_mm;
    const CenterlineTree tree = extract_centerlines(mask, so, "patient " + src.id);
    const int shift = static_cast<int>(all.branches.size());
    for (auto b : tree.branches) {
      if (b.parent >= 0) b.parent += shift;
      all.branches.push_back(std::move(b));
    }
    // Branch indices in the labels refer to centerlines.json (both systems).
    const auto points = flatten_centerlines(all, system);
    ContrastRecipe recipe;
    recipe.preset = o.recipe;
    const bool mesh_mode = o.vessel_mode == VesselMode::mesh;
    const Volume<float> mu =
        make_attenuation(hu, mesh_mode ? nullptr : &mask, recipe, "patient " + src.id);
    // The voxel mask projects through its bounding box only (a few % of the CT grid), as 0/1
    // floats with its empty blocks found once for all views.
    const Volume<float> vessel_box =
        mesh_mode ? Volume<float>() : unit_mask(crop_to_foreground(mask, 1));
    const EmptyBlocks vessel_blocks = mesh_mode ? EmptyBlocks() : EmptyBlocks(vessel_box);
    const EmptyBlocks mu_blocks(mu);
    std::optional<VesselMeshProjector> mesh_projector;
    double lumen_gain = 0;  // mm^-1 the lumen adds over the (uninjected) background, mesh mode
    if (mesh_mode) {
      mesh_projector.emplace(mesh_from_mask(mask));
      double injected = 0, plain = 0;
      std::size_t count = 0;
      for (std::size_t n = 0; n < mask.size(); ++n)
        if (mask.data()[n]) {
          injected += recipe.mu(hu.data()[n], true);
          plain += recipe.mu(hu.data()[n], false);
          ++count;
        }
      lumen_gain = count ? (injected - plain) / count : 0.0;
    }
    const ViewPlan plan = plan_views(system, o.view_mode, rng);
    const Eigen::Vector3d centre = [&] {
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      for (const auto& p : points) sum += p.world;
      return Eigen::Vector3d(sum / std::max<std::size_t>(1, points.size()));
    }();
    std::vector<Camerad> cameras;
    std::vector<std::vector<ProjectedPoint>> projected;
    std::vector<std::string> names;
    // A view's outputs (exp and 16-bit PNG, labels, mask PNG, JSON: serial work) are written on
    // a helper thread while the next view renders on every core; one view in flight at a time.
    // Declared after everything the task reads, so an exception here waits for it first.
    const auto views_start = std::chrono::steady_clock::now();
    std::future<std::vector<ProjectedPoint>> in_flight;
    const auto collect = [&] {
      if (in_flight.valid()) projected.push_back(in_flight.get());
    };
    for (std::size_t v = 0; v < plan.views.size(); ++v) {
      CArm carm = o.carm;
      carm.primary_deg = plan.views[v].primary_deg;
      carm.secondary_deg = plan.views[v].secondary_deg;
      carm.isocenter = centre;
      const Camerad camera = carm.camera();
      const std::string name = std::string(to_string(system)) + "_" + detail::two_digits(v);
      DrrOptions drr;
      drr.projector = o.projector;
      drr.empty_blocks = &mu_blocks;
      Image<float> integrals = render_line_integrals(mu, camera, drr);
      Image<std::uint8_t> vessel, overlap;
      if (mesh_mode) {
        const VesselProjection vp = mesh_projector->project(camera);
        vessel = Image<std::uint8_t>(camera.rows(), camera.cols(), 0);
        for (std::size_t p = 0; p < integrals.size(); ++p) {
          integrals.data()[p] += static_cast<float>(lumen_gain * vp.chord_mm.data()[p]);
          vessel.data()[p] = vp.chord_mm.data()[p] > 0;
        }
        overlap = vp.passages;
      } else {
        vessel = project_unit_mask(vessel_box, camera, 1e-6, &vessel_blocks);
      }
      nlohmann::json cj = to_json(carm);
      cj["view_class"] = plan.views[v].view_class;
      cj["view_name"] = view_class(plan.views[v].view_class).name;
      cj["system"] = to_string(system);
      collect();
      in_flight =
          std::async(std::launch::async,
                     [&, integrals = std::move(integrals), vessel = std::move(vessel),
                      overlap = std::move(overlap), cj = std::move(cj), camera, name]() mutable {
                       return detail::write_view(dir / "views" / name, integrals, std::move(vessel),
                                                 mesh_mode ? &overlap : nullptr, cj, camera, points,
                                                 mesh_mode ? &*mesh_projector : nullptr);
                     });
      cameras.push_back(camera);
      names.push_back(name);
    }
    collect();
    view_seconds +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - views_start).count();
    std::size_t dense_total = 0;
    for (const auto& pr : plan.pairs) {
      const PairLabels labels = label_pair(points, projected[pr.a], projected[pr.b], cameras[pr.a],
                                           cameras[pr.b], o.sparse_count, rng);
      dense_total += labels.dense.size();
      const std::string name = names[pr.a] + "-" + names[pr.b].substr(4);
      write_json_file(
          dir / "pairs" / (name + ".json"),
          detail::pair_json(labels, plan.views[pr.a], plan.views[pr.b], names[pr.a], names[pr.b]),
          -1);
    }
    record["systems"][to_string(system)] = {{"views", plan.views.size()},
                                            {"pairs", plan.pairs.size()},
                                            {"centerline_mm", tree.length()},
                                            {"dense_labels", dense_total}};
  }
  write_json_file(dir / "centerlines.json", to_json(all), -1);
  record["status"] = "ok";
  record["seconds"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  record["view_seconds"] = view_seconds;
  nlohmann::json stored = record;
  stored.erase("seconds");  // timing varies run to run; done.json must not
  stored.erase("view_seconds");
  stored["run"] = patient_run(src, o);
  write_json_file(dir / "done.json", stored);
  return record;
}

}  // namespace gimm
