// The named steps of generate_patient (pipeline/patient.hpp) one by one: read_patient,
// system_renderer, render_system_views, label_system_pairs, vessel_isocenter,
// view_camera_json, absent_system_record; and the pieces they stand on: CenterlineTree::append
// (anatomy/centerlines.hpp) and crop_to_foreground (core/volume.hpp).
#include <Eigen/Geometry>
#include <algorithm>
#include <catch2/catch.hpp>
#include <filesystem>

#include "gimm/io/nifti.hpp"
#include "gimm/pipeline/patient.hpp"
#include "pipeline_fixtures.hpp"

namespace fs = std::filesystem;
using namespace gimm;
using nlohmann::json;

namespace {

fs::path fresh_dir(const std::string& name) {
  return gimm_test::fresh_pipeline_dir("patient_steps", name, true);
}

PatientSource phantom_source(std::uint64_t seed) {
  PatientSource src;
  src.id = "ph" + std::to_string(seed);
  src.phantom_seed = seed;
  src.phantom_size = PhantomSize::small;
  return src;
}

/// The small phantom of seed 5 as read_patient gives it (built once for the file).
const PatientVolumes& patient5() {
  static const PatientVolumes v = read_patient(phantom_source(5));
  return v;
}

/// A tiny detector with large pixels: 64 x 64 at 3 mm (144 mm at the isocentre: the heart).
DatasetOptions tiny_views(VesselMode mode) {
  DatasetOptions o;
  o.carm.rows = o.carm.cols = 64;
  o.carm.pixel_mm = 3.0;
  o.vessel_mode = mode;
  return o;
}

CenterlineBranch branch(const std::string& name, int parent, double x, CoronarySystem system) {
  CenterlineBranch b;
  b.name = name;
  b.parent = parent;
  b.system = system;
  b.points = {Eigen::Vector3d(x, 0, 0), Eigen::Vector3d(x, 1, 0), Eigen::Vector3d(x, 2, 1)};
  b.radii = {1.5, 1.4, 1.2};
  return b;
}

}  // namespace

TEST_CASE("Patient steps: read_patient builds the phantom of the seed on one grid",
          "[pipeline][patient_steps]") {
  const PatientVolumes& v = patient5();
  CHECK(grid_difference(v.hu.geometry(), v.label.geometry()).empty());
  CHECK(grid_difference(v.hu.geometry(), phantom_grid(PhantomSize::small)).empty());
  // The phantom of that seed, its HU as float.
  PhantomOptions po;
  po.seed = 5;
  const Phantom p = make_phantom(po);
  CHECK(v.label.storage() == p.label.storage());
  REQUIRE(v.hu.size() == p.hu.size());
  bool same_hu = true;
  for (std::size_t n = 0; n < v.hu.size(); ++n)
    same_hu = same_hu && v.hu.data()[n] == static_cast<float>(p.hu.data()[n]);
  CHECK(same_hu);
  CHECK(std::count(v.label.storage().begin(), v.label.storage().end(), 1) > 500);  // 896
}

TEST_CASE("Patient steps: read_patient from files: a missing label is an IoError naming it",
          "[pipeline][patient_steps]") {
  const fs::path in = fresh_dir("files");
  VolumeGeometry g;
  g.dims = {6, 5, 4};
  g.spacing = {0.5, 0.6, 0.7};
  g.origin = {1, 2, 3};
  Volume<float> hu(g, 40.0f);
  hu(1, 2, 3) = 300.0f;
  Volume<std::uint8_t> label(g, 0);
  label(2, 2, 2) = 1;
  PatientSource src;
  src.id = "f1";
  src.image = in / "f1.img.nii.gz";
  src.label = in / "f1.label.nii.gz";
  write_nifti(src.image, hu);

  // The label is not there: an IoError with the patient and the path.
  CHECK_THROWS_AS(read_patient(src), IoError);
  CHECK_THROWS_WITH(read_patient(src), Catch::Contains("patient f1") &&
                                           Catch::Contains(src.label.string()) &&
                                           Catch::Contains("missing"));

  // Both files there: read back on one grid.
  write_nifti(src.label, label);
  const PatientVolumes v = read_patient(src);
  CHECK(grid_difference(v.hu.geometry(), g).empty());
  CHECK(v.hu(1, 2, 3) == 300.0f);
  CHECK(v.label(2, 2, 2) == 1);
  CHECK(std::count(v.label.storage().begin(), v.label.storage().end(), 1) == 1);

  // A label on another grid: an error naming what differs.
  VolumeGeometry shifted = g;
  shifted.origin.x() += 5;
  write_nifti(src.label, Volume<std::uint8_t>(shifted, 0));
  CHECK_THROWS_WITH(read_patient(src), Catch::Contains("patient f1") &&
                                           Catch::Contains("grids disagree") &&
                                           Catch::Contains("origin"));
}

TEST_CASE(
    "Patient steps: render_system_views writes every view of the plan, "
    "label_system_pairs every pair",
    "[pipeline][patient_steps]") {
  const VesselMode mode = GENERATE(VesselMode::voxel, VesselMode::mesh);
  INFO(to_string(mode) << " vessels");
  const PatientVolumes& patient = patient5();
  const std::string id = "ph5";
  const DatasetOptions o = tiny_views(mode);
  const CoronarySplit split = split_coronary_systems(patient.label);
  REQUIRE(split.lca_voxels > 0);
  ContrastRecipe recipe;
  const DenseTissue dense = classify_dense_tissue(patient.hu, recipe);
  SkeletonOptions so;
  so.system = CoronarySystem::LCA;
  CenterlineTree all;
  all.append(extract_centerlines(split.lca, so, id));
  const std::vector<LabelPoint> points = flatten_centerlines(all, CoronarySystem::LCA);
  REQUIRE(points.size() > 20);

  const ViewRenderer renderer = system_renderer(patient.hu, split.lca, o, id, &dense);
  CHECK(renderer.options().vessels == mode);
  CHECK(renderer.options().pad_mm == o.pad_mm);
  CHECK(renderer.options().recipe.preset == o.preset);
  CHECK(renderer.has_vessels());

  Rng rng(17);
  const ViewPlan plan = plan_views(CoronarySystem::LCA, o.view_mode, rng);
  REQUIRE(plan.views.size() == 7);
  const fs::path out = fresh_dir(std::string("views_") + to_string(mode));
  const DatasetWriter writer(out);
  writer.create_patient(id);
  PatientTimings t;
  const Eigen::Vector3d isocenter = vessel_isocenter(split.lca);
  // Line integrals written in mesh mode only, to see the flag decide it.
  const bool npy = mode == VesselMode::mesh;
  const SystemViews views =
      render_system_views(renderer, plan, o.carm, isocenter, points, writer, id, npy, t);
  REQUIRE(views.cameras.size() == plan.views.size());
  REQUIRE(views.projected.size() == plan.views.size());
  REQUIRE(views.names.size() == plan.views.size());
  CHECK(t.writes > 0);

  const fs::path vdir = writer.layout().views_dir(id);
  std::size_t on_mask = 0;
  for (std::size_t v = 0; v < plan.views.size(); ++v) {
    INFO("view " << v);
    CHECK(views.names[v] == view_name("LCA", v));
    // The camera of view v: the plan's angles about the lumen centroid.
    CArm carm = o.carm;
    carm.primary_deg = plan.views[v].primary_deg;
    carm.secondary_deg = plan.views[v].secondary_deg;
    carm.isocenter = isocenter;
    CHECK(views.cameras[v].P().isApprox(carm.camera().P()));
    // The labels of view v are those of camera v (the writes run on a helper thread, one view
    // behind: collected out of order they would belong to another camera).
    REQUIRE(views.projected[v].size() == points.size());
    for (std::size_t n = 0; n < points.size(); ++n)
      REQUIRE(views.projected[v][n].uv == views.cameras[v].project(points[n].world).uv);
    // The files, and what they hold: the camera record, the mask of this view's render.
    const fs::path stem = vdir / views.names[v];
    for (const char* suffix : {".png", ".mask.png", ".camera.json", ".points.json"})
      CHECK(fs::exists(stem.string() + suffix));
    CHECK(fs::exists(stem.string() + ".overlap.png") == (mode == VesselMode::mesh));
    CHECK(fs::exists(stem.string() + ".npy") == npy);
    const json camera = read_json_file(stem.string() + ".camera.json");
    CHECK(camera["system"] == "LCA");
    CHECK(camera["view_class"] == plan.views[v].view_class);
    CHECK(camera["primary_deg"].get<double>() == plan.views[v].primary_deg);
    CHECK(camera["secondary_deg"].get<double>() == plan.views[v].secondary_deg);
    const RenderedView rendered = renderer.render(views.cameras[v]);
    const Image<std::uint8_t> mask = read_png8(stem.string() + ".mask.png");
    REQUIRE(mask.rows() == o.carm.rows);
    REQUIRE(mask.cols() == o.carm.cols);
    bool same_mask = true;
    for (std::size_t p = 0; p < mask.size(); ++p)
      same_mask = same_mask && mask.data()[p] == (rendered.vessel_mask.data()[p] ? 255 : 0);
    CHECK(same_mask);
    const json pj = read_json_file(stem.string() + ".points.json");
    CHECK(pj["u"].size() == points.size());
    for (const auto& p : views.projected[v]) on_mask += p.on_mask;
  }
  CHECK(on_mask > points.size());  // the centerlines land on their vessels' masks

  // The pairs: one file each; the total returned is the dense labels written.
  const std::size_t dense_total = label_system_pairs(plan, views, points, o, writer, id, t);
  REQUIRE(plan.pairs.size() == 21);
  std::size_t written = 0, files = 0;
  for (const auto& e : fs::directory_iterator(writer.layout().pairs_dir(id))) {
    ++files;
    written += read_json_file(e.path())["dense"].size();
  }
  CHECK(files == plan.pairs.size());
  CHECK(dense_total == written);
  CHECK(dense_total > 0);
  CHECK(t.pairs > 0);
}

TEST_CASE("Patient steps: --vessels tubes images and labels the phantom's own tubes",
          "[pipeline][patient_steps][tubes]") {
  const PatientVolumes& patient = patient5();
  PhantomOptions po;
  po.seed = 5;
  const Phantom p = make_phantom(po);
  REQUIRE(patient.tubes);
  REQUIRE(patient.tubes->branches.size() == p.centerlines.branches.size());
  CHECK(patient.tubes->branches[0].points == p.centerlines.branches[0].points);
  const CenterlineTree axes = tube_axes(*patient.tubes);

  std::shared_ptr<const VesselSurface> surface;
  const CenterlineTree tree = system_tubes(patient, CoronarySystem::LCA, "ph5", surface);
  REQUIRE(surface);
  CHECK_NOTHROW(tree.validate("LCA tubes"));
  std::size_t lca = 0;
  for (const auto& b : p.centerlines.branches) lca += b.system == CoronarySystem::LCA;
  CHECK(tree.branches.size() == lca);
  for (std::size_t b = 0, a = 0; b < tree.branches.size(); ++b, ++a) {
    CHECK(tree.branches[b].system == CoronarySystem::LCA);
    while (axes.branches[a].system != CoronarySystem::LCA) ++a;
    CHECK(tree.branches[b].points == axes.branches[a].points);  // the labelled axes are the tubes'
  }

  // Rendered with the tubes, every in-image centreline point lies on its vessel's mask.
  DatasetOptions o;
  o.carm.rows = o.carm.cols = 256;
  o.carm.pixel_mm = 1.0;
  o.vessel_mode = VesselMode::mesh;
  o.phantom_tubes = true;
  const CoronarySplit split = split_coronary_systems(patient.label);
  const DenseTissue dense = classify_dense_tissue(patient.hu, ContrastRecipe{});
  const ViewRenderer renderer =
      system_renderer(patient.hu, split.lca, o, "ph5", &dense, nullptr, surface);
  CArm carm;  // o.carm's values (a copy of its empty optional warns with GCC 12 -O2)
  carm.rows = carm.cols = 256;
  carm.pixel_mm = 1.0;
  carm.primary_deg = -30;
  carm.secondary_deg = 25;
  carm.isocenter = vessel_isocenter(split.lca);
  const Camerad camera = carm.camera();
  const RenderedView view = renderer.render(camera);
  std::size_t seen = 0, on_mask = 0;
  for (const LabelPoint& q : flatten_centerlines(tree, CoronarySystem::LCA)) {
    const Eigen::Vector2d uv = camera.project(q.world).uv;
    const long c = std::lround(uv.x()), r = std::lround(uv.y());
    if (r < 0 || c < 0 || r >= carm.rows || c >= carm.cols) continue;
    ++seen;
    on_mask += view.vessel_mask(static_cast<int>(r), static_cast<int>(c)) != 0;
  }
  INFO(on_mask << " of " << seen << " points on the mask");
  REQUIRE(seen > 300);
  CHECK(on_mask == seen);

  // A CT patient has no analytic tubes: named, not guessed.
  PatientVolumes ct{patient.hu, patient.label, std::nullopt, std::nullopt};
  CHECK_THROWS_WITH(system_tubes(ct, CoronarySystem::LCA, "ct7", surface),
                    Catch::Contains("patient ct7") && Catch::Contains("need a phantom patient"));
}

TEST_CASE("Patient steps: the small records", "[pipeline][patient_steps]") {
  // vessel_isocenter: the centroid of the lumen voxels in world mm (not index space); an empty
  // mask is an error, not NaN. grid_center: the middle of the grid.
  VolumeGeometry g;
  g.dims = {4, 6, 8};
  g.spacing = {0.5, 2.0, 1.0};
  g.origin = {10, -20, 30};
  Volume<std::uint8_t> lumen(g, 0);
  lumen(1, 2, 3) = 1;
  lumen(3, 4, 5) = 1;
  CHECK(vessel_isocenter(lumen).isApprox(lumen.index_to_world(Eigen::Vector3d(2, 3, 4))));
  CHECK(vessel_isocenter(lumen).isApprox(Eigen::Vector3d(11, -14, 34)));
  CHECK(grid_center(lumen).isApprox(lumen.index_to_world(Eigen::Vector3d(1.5, 2.5, 3.5))));
  CHECK_THROWS_WITH(vessel_isocenter(Volume<std::uint8_t>(g, 0), "lca"),
                    Catch::Contains("lca") && Catch::Contains("empty"));

  // patient_stream: one stream per patient and purpose, each its own.
  DatasetOptions so;
  so.seed = 3;
  CHECK(patient_stream(so, "p", "views:LCA").next_u64() ==
        patient_stream(so, "p", "views:LCA").next_u64());
  CHECK(patient_stream(so, "p", "views:LCA").next_u64() !=
        patient_stream(so, "p", "views:RCA").next_u64());
  CHECK(patient_stream(so, "p", "views:LCA").next_u64() !=
        patient_stream(so, "q", "views:LCA").next_u64());

  // view_camera_json: the C-arm, the view class and its name, the system.
  CArm carm;
  carm.primary_deg = 30;
  carm.secondary_deg = -20;
  SampledView view;
  view.view_class = views_of(CoronarySystem::RCA).front().id;
  view.primary_deg = 30;
  view.secondary_deg = -20;
  const json j = view_camera_json(carm, view, CoronarySystem::RCA);
  CHECK(j["system"] == "RCA");
  CHECK(j["view_class"] == view.view_class);
  CHECK(j["view_name"] == view_class(view.view_class).name);
  CHECK(j["primary_deg"] == 30.0);
  CHECK(camera_from_json(j).P().isApprox(carm.camera().P()));

  const json absent = absent_system_record();
  CHECK(absent["present"] == false);
  for (const char* zero : {"voxels", "views", "pairs", "dense_labels"}) CHECK(absent[zero] == 0);
}

TEST_CASE("CenterlineTree::append shifts the parent indices of the appended tree",
          "[pipeline][patient_steps][centerlines]") {
  CenterlineTree rca;
  rca.branches = {branch("RCA", -1, 0, CoronarySystem::RCA),
                  branch("PDA", 0, 1, CoronarySystem::RCA)};
  CenterlineTree lca;
  lca.branches = {branch("LM", -1, 10, CoronarySystem::LCA),
                  branch("LAD", 0, 11, CoronarySystem::LCA),
                  branch("D1", 1, 12, CoronarySystem::LCA)};
  CenterlineTree all;
  all.append(rca);
  all.append(lca);
  REQUIRE(all.branches.size() == 5);
  // Roots stay roots; the others point at the same branch in the new numbering.
  const int expected_parent[] = {-1, 0, -1, 2, 3};
  for (int b = 0; b < 5; ++b) {
    INFO("branch " << b << " " << all.branches[b].name);
    CHECK(all.branches[b].parent == expected_parent[b]);
    if (all.branches[b].parent >= 0) {
      const auto& parent = all.branches[all.branches[b].parent];
      CHECK(parent.system == all.branches[b].system);
    }
  }
  CHECK(all.branches[4].name == "D1");
  CHECK(all.branches[3].points == lca.branches[1].points);
  CHECK(all.branches[3].radii == lca.branches[1].radii);
  CHECK_NOTHROW(all.validate("appended"));
  CHECK(all.length() == Approx(rca.length() + lca.length()));
  // The source tree is untouched.
  CHECK(lca.branches[2].parent == 1);
  // Appending to an empty tree changes nothing.
  CenterlineTree copy;
  copy.append(lca);
  CHECK(copy.branches[2].parent == 1);
}

TEST_CASE("crop_to_foreground keeps world positions", "[pipeline][patient_steps][volume]") {
  VolumeGeometry g;
  g.dims = {20, 17, 13};
  g.spacing = {0.7, 1.1, 1.3};
  g.origin = {3, -2, 5};
  g.direction = Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, -2, 3).normalized()).toRotationMatrix();
  Volume<std::int16_t> mask(g, 0);
  mask(5, 6, 7) = 3;
  mask(9, 4, 8) = -2;
  mask(6, 10, 5) = 1;
  const int margin = 2;
  const Volume<std::uint8_t> crop = crop_to_foreground(mask, margin);
  // The box of (5..9, 4..10, 5..8) grown by 2.
  CHECK(crop.dims() == std::array<int, 3>{9, 11, 8});
  CHECK(crop.spacing() == g.spacing);
  CHECK(crop.direction() == g.direction);
  // Every crop voxel sits at the world point of the mask voxel it copies, and holds its 0/1.
  int foreground = 0;
  for (int k = 0; k < crop.nz(); ++k)
    for (int j = 0; j < crop.ny(); ++j)
      for (int i = 0; i < crop.nx(); ++i) {
        const Eigen::Vector3d world = crop.index_to_world(Eigen::Vector3d(i, j, k));
        const Eigen::Vector3d ijk = mask.world_to_index(world);
        const Eigen::Vector3i n = ijk.array().round().cast<int>();
        INFO("crop voxel (" << i << ", " << j << ", " << k << ")");
        REQUIRE((ijk - n.cast<double>()).norm() < 1e-9);
        REQUIRE(n == Eigen::Vector3i(i + 3, j + 2, k + 3));
        REQUIRE(crop(i, j, k) == (mask(n[0], n[1], n[2]) != 0 ? 1 : 0));
        foreground += crop(i, j, k);
      }
  CHECK(foreground == 3);

  // At the grid's edge the margin is clamped: the corner voxel's crop starts at the grid origin.
  Volume<std::uint8_t> corner(g, 0);
  corner(0, 0, 0) = 1;
  corner(19, 1, 0) = 1;
  const Volume<std::uint8_t> edge = crop_to_foreground(corner, 3);
  CHECK(edge.dims() == std::array<int, 3>{20, 5, 4});
  CHECK((edge.origin() - g.origin).norm() < 1e-12);
  CHECK(edge(19, 1, 0) == 1);
  // An empty mask: one empty voxel.
  const Volume<std::uint8_t> none = crop_to_foreground(Volume<std::uint8_t>(g, 0), 1);
  CHECK(none.dims() == std::array<int, 3>{1, 1, 1});
  CHECK(none(0, 0, 0) == 0);
}
