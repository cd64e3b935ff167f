// The prepared view renderer (render/view_renderer.hpp): bit for bit the hand-assembled
// pipeline, vessel depth and overlap in voxel mode against the mask walk, occlusion, mesh mode
// against voxel mode and the lumen gain, and the inputs it refuses.
//
// The scene: a 40^3 CT (1 mm voxels, centred on the world origin) of soft tissue in air with a
// bone column and a blood pool, and two coronary-like tubes (radius 2.5 mm, along x, at z = 0):
// the near tube at y = +7 over x in [-14, 3], the far tube at y = -7 over x in [-3, 14]. In AP
// (primary = secondary = 0) the source is posterior (+y), so the near tube lies in front of the
// far one where their x ranges meet (x in [-3, 3]): two passages there, one elsewhere.
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <memory>
#include <sstream>
#include <vector>

#include "gimm/anatomy/attenuation.hpp"
#include "gimm/core/rng.hpp"
#include "gimm/geometry/carm.hpp"
#include "gimm/render/drr.hpp"
#include "gimm/render/empty_space.hpp"
#include "gimm/render/padded_attenuation.hpp"
#include "gimm/render/siddon.hpp"
#include "gimm/render/vessel_mesh_projector.hpp"
#include "gimm/render/view_renderer.hpp"

using namespace gimm;

namespace {

constexpr double kTubeRadius = 2.5;
constexpr float kTubeHu = 350;  // CCTA-enhanced lumen: dense tissue, classified as blood

/// Distance from p to the axis segment of a tube along x at (y0, z0) over [x0, x1]; infinite
/// beyond its flat ends.
double tube_distance(const Eigen::Vector3d& p, double x0, double x1, double y0, double z0) {
  if (p.x() < x0 || p.x() > x1) return std::numeric_limits<double>::infinity();
  return std::hypot(p.y() - y0, p.z() - z0);
}

struct Scene {
  Volume<float> hu;
  Volume<std::uint8_t> tubes;  ///< both tubes (the injected system)
  Volume<std::uint8_t> near_tube, far_tube;
};

const Scene& scene() {
  static const Scene s = [] {
    VolumeGeometry g;
    g.dims = {40, 40, 40};
    g.origin = Eigen::Vector3d::Constant(-19.5);
    Scene out{Volume<float>(g, -1000.0f), Volume<std::uint8_t>(g, 0), Volume<std::uint8_t>(g, 0),
              Volume<std::uint8_t>(g, 0)};
    Rng rng(11);
    for (int k = 0; k < 40; ++k)
      for (int j = 0; j < 40; ++j)
        for (int i = 0; i < 40; ++i) {
          const Eigen::Vector3d p = out.hu.index_to_world(Eigen::Vector3d(i, j, k));
          float& hu = out.hu(i, j, k);
          // An elliptic body cylinder along z (the axial pads carry it on), noisy soft tissue.
          if (std::pow(p.x() / 18, 2) + std::pow(p.y() / 15, 2) < 1)
            hu = static_cast<float>(40 + 10 * rng.normal());
          // A bone column: bright cortex around marrow (classified bone by its shell).
          if (p.x() > -16 && p.x() < -10 && p.y() > -3 && p.y() < 3) {
            const bool cortex = p.x() < -15 || p.x() > -11 || p.y() < -2 || p.y() > 2;
            hu = cortex ? 1200.0f : 300.0f;
          }
          // A blood pool (uniform: blood).
          if ((p - Eigen::Vector3d(8, 6, -10)).norm() < 4) hu = 450.0f;
          if (tube_distance(p, -14, 3, 7, 0) < kTubeRadius) out.near_tube(i, j, k) = 1;
          if (tube_distance(p, -3, 14, -7, 0) < kTubeRadius) out.far_tube(i, j, k) = 1;
          if (out.near_tube(i, j, k) || out.far_tube(i, j, k)) {
            out.tubes(i, j, k) = 1;
            hu = kTubeHu;
          }
        }
    return out;
  }();
  return s;
}

CArm small_carm(double primary, double secondary, double pixel_mm = 1.2,
                ProjectionModel model = ProjectionModel::perspective) {
  CArm carm;
  carm.primary_deg = primary;
  carm.secondary_deg = secondary;
  carm.rows = carm.cols = 48;
  carm.pixel_mm = pixel_mm;
  carm.model = model;
  return carm;
}

/// The views of the equivalence test: AP, two oblique views whose rays cross the axial pads,
/// and an orthographic one.
std::vector<Camerad> test_cameras() {
  return {small_carm(0, 0).camera(), small_carm(35, 25).camera(), small_carm(-50, -30).camera(),
          small_carm(20, 40, 1.2, ProjectionModel::orthographic).camera()};
}

/// The (row, col) of the pixel nearest to the projection of world point X.
std::pair<int, int> pixel_of(const Camerad& camera, const Eigen::Vector3d& X) {
  const Eigen::Vector2d uv = camera.project(X).uv;
  return {static_cast<int>(std::lround(uv.y())), static_cast<int>(std::lround(uv.x()))};
}

}  // namespace

TEST_CASE("View renderer: equals the hand-assembled pipeline bit for bit",
          "[render][view_renderer]") {
  const Scene& s = scene();
  const Projector projector = GENERATE(Projector::siddon, Projector::trilinear);
  const ContrastPreset preset = GENERATE(ContrastPreset::angiography, ContrastPreset::reference);
  const double pad_mm = GENERATE(0.0, 20.0);
  INFO(to_string(projector) << ", " << to_string(preset) << ", pad " << pad_mm << " mm");

  RendererOptions options;
  options.recipe.preset = preset;
  options.pad_mm = pad_mm;
  options.projector = projector;
  options.step_mm = projector == Projector::trilinear ? 0.4 : 0.0;
  const ViewRenderer renderer(s.hu, &s.tubes, options);
  REQUIRE(renderer.has_vessels());

  // By hand: the padded attenuation with the injection, its empty blocks, the line integrals
  // through the scan and its pads; the vessel mask through the mask's box.
  ContrastRecipe recipe;
  recipe.preset = preset;
  const PaddedAttenuation mu = padded_attenuation(s.hu, &s.tubes, recipe, pad_mm, projector);
  // Breaking: dropping the pads (pad 20 differs from pad 0 only there) or the injection.
  CHECK(mu.pads.empty() == (pad_mm == 0 || projector == Projector::trilinear));
  const EmptyBlocks blocks(mu.mu);
  DrrOptions drr;
  drr.projector = projector;
  drr.step_mm = options.step_mm;
  drr.empty_blocks = &blocks;
  const Volume<float> box = unit_mask(crop_to_foreground(s.tubes, 1));

  for (const Camerad& camera : test_cameras()) {
    const RenderedView view = renderer.render(camera);
    const Image<float> expected = render_line_integrals(mu.mu, mu.pads, camera, drr);
    const Image<std::uint8_t> expected_mask = project_unit_mask(box, camera);
    REQUIRE(view.line_integrals.rows() == camera.rows());
    REQUIRE(view.line_integrals.cols() == camera.cols());
    CHECK(view.line_integrals.storage() == expected.storage());
    CHECK(view.vessel_mask.storage() == expected_mask.storage());
    // Without vessel_depth the voxel mode has no depth or overlap images.
    CHECK(view.depth_mm.empty());
    CHECK(view.overlap.empty());
    // Intensity is Beer-Lambert of the line integrals.
    CHECK(view.intensity().storage() == beer_lambert(expected).storage());
  }
  // The mask is not empty, the views see tissue, and the attenuation kept is the hand-made one.
  const RenderedView ap = renderer.render(test_cameras()[0]);
  CHECK(std::count(ap.vessel_mask.storage().begin(), ap.vessel_mask.storage().end(), 1) > 50);
  CHECK(renderer.attenuation().mu.storage() == mu.mu.storage());
}

TEST_CASE("View renderer: from_attenuation and recipe none equal the hand-assembled pipeline",
          "[render][view_renderer]") {
  const Scene& s = scene();
  const Projector projector = GENERATE(Projector::siddon, Projector::trilinear);
  const double pad_mm = GENERATE(0.0, 20.0);
  ContrastRecipe recipe;
  recipe.preset = ContrastPreset::reference;
  const Volume<float> mu = make_attenuation(s.hu, &s.tubes, recipe);
  RendererOptions options;
  options.pad_mm = pad_mm;
  options.projector = projector;
  options.recipe.preset = ContrastPreset::angiography;  // from_attenuation overrides it
  const ViewRenderer moved = ViewRenderer::from_attenuation(Volume<float>(mu), options);
  CHECK(moved.options().recipe.preset == ContrastPreset::none);
  CHECK_FALSE(moved.has_vessels());
  options.recipe.preset = ContrastPreset::none;
  const ViewRenderer copied(mu, nullptr, options);
  const PaddedAttenuation padded = padded_attenuation(mu, pad_mm, projector);
  DrrOptions drr;
  drr.projector = projector;
  for (const Camerad& camera : test_cameras()) {
    const Image<float> expected = render_line_integrals(padded.mu, padded.pads, camera, drr);
    const RenderedView a = moved.render(camera), b = copied.render(camera);
    CHECK(a.line_integrals.storage() == expected.storage());
    CHECK(b.line_integrals.storage() == expected.storage());
    CHECK(a.vessel_mask.empty());
    // No vessels: nothing is occluded.
    CHECK(moved.unoccluded(camera, Eigen::Vector3d(0, -7, 0)));
  }
}

TEST_CASE("View renderer: volume views render as the volumes they view",
          "[render][view_renderer]") {
  const Scene& s = scene();
  std::vector<float> hu(s.hu.begin(), s.hu.end());
  std::vector<std::uint8_t> tubes(s.tubes.begin(), s.tubes.end());
  const Volume<float> hu_view = Volume<float>::view(s.hu.geometry(), hu.data());
  const Volume<std::uint8_t> tubes_view =
      Volume<std::uint8_t>::view(s.tubes.geometry(), tubes.data());
  RendererOptions options;
  options.vessel_depth = true;
  const ViewRenderer owned(s.hu, &s.tubes, options), viewed(hu_view, &tubes_view, options);
  const Camerad camera = test_cameras()[1];
  const RenderedView a = owned.render(camera), b = viewed.render(camera);
  CHECK(a.line_integrals.storage() == b.line_integrals.storage());
  CHECK(a.vessel_mask.storage() == b.vessel_mask.storage());
  CHECK(a.depth_mm.storage() == b.depth_mm.storage());

  // Attenuation given as a view is copied in: the renderer outlives the caller's buffer.
  ContrastRecipe recipe;
  recipe.preset = ContrastPreset::reference;
  const Volume<float> mu = make_attenuation(s.hu, &s.tubes, recipe);
  std::vector<float> mu_buffer(mu.begin(), mu.end());
  RendererOptions none;
  none.recipe.preset = ContrastPreset::none;
  const ViewRenderer from_view =
      ViewRenderer::from_attenuation(Volume<float>::view(mu.geometry(), mu_buffer.data()), none);
  const ViewRenderer from_volume = ViewRenderer::from_attenuation(Volume<float>(mu), none);
  CHECK(from_view.attenuation().mu.owns_data());
  const Image<float> before = from_view.render(camera).line_integrals;
  std::fill(mu_buffer.begin(), mu_buffer.end(), 1.0f);
  mu_buffer = {};  // freed
  CHECK(from_view.render(camera).line_integrals.storage() == before.storage());
  CHECK(from_volume.render(camera).line_integrals.storage() == before.storage());
}

TEST_CASE("View renderer: voxel depth and overlap equal the mask walk per pixel",
          "[render][view_renderer]") {
  const Scene& s = scene();
  RendererOptions options;
  options.vessel_depth = true;
  const ViewRenderer renderer(s.hu, &s.tubes, options);
  const Camerad ap = small_carm(0, 0, 1.0).camera();
  const Camerad oblique = small_carm(30, -20, 1.0).camera();
  for (const Camerad& camera : {ap, oblique}) {
    const RenderedView view = renderer.render(camera);
    REQUIRE(view.depth_mm.rows() == camera.rows());
    REQUIRE(view.overlap.rows() == camera.rows());
    // The walk through the full (uncropped) mask on the grid of the CT, ray by ray through the
    // camera: the renderer's crop to the vessels' box keeps world positions and world mm.
    const IndexSpace to_index(s.tubes.geometry());
    int vessel = 0;
    for (int r = 0; r < camera.rows(); ++r)
      for (int c = 0; c < camera.cols(); ++c) {
        const MaskRayHits hits = siddon_mask_hits(s.tubes, to_index(camera.ray(c, r)));
        INFO("pixel (" << r << ", " << c << ")");
        REQUIRE(view.overlap(r, c) == hits.passages);
        if (hits.passages == 0)
          REQUIRE(std::isinf(view.depth_mm(r, c)));
        else
          REQUIRE(view.depth_mm(r, c) == Approx(hits.first_hit_mm).epsilon(1e-6));
        // The 2D mask (a chord of at least 1e-6 mm) is the set of pixels with a passage.
        REQUIRE((view.vessel_mask(r, c) != 0) == (hits.passages > 0));
        vessel += hits.passages > 0;
      }
    CHECK(vessel > 100);
  }

  // AP: two passages where the tubes overlap, one on either tube alone, none beside them.
  const RenderedView view = renderer.render(ap);
  const auto at = [&](const Eigen::Vector3d& X) {
    const auto [r, c] = pixel_of(ap, X);
    return std::make_pair(view.overlap(r, c), view.depth_mm(r, c));
  };
  CHECK(at({0, 0, 0}).first == 2);
  CHECK(at({-10, 7, 0}).first == 1);
  CHECK(at({10, -7, 0}).first == 1);
  CHECK(at({0, 0, 12}).first == 0);
  CHECK(std::isinf(at({0, 0, 12}).second));
  // Depth: the source is 750 mm behind the isocentre on +y; the near tube's voxels reach
  // y = 9 (centres within 2.5 mm of y = 7), the far tube's y = -5.
  CHECK(at({0, 0, 0}).second == Approx(750 - 9).margin(0.5));
  CHECK(at({-10, 7, 0}).second == Approx(750 - 9).margin(0.5));
  CHECK(at({10, -7, 0}).second == Approx(750 + 5).margin(0.5));
  int overlap2 = 0, overlap1 = 0, more = 0;
  for (const auto o : view.overlap.storage()) {
    overlap2 += o == 2;
    overlap1 += o == 1;
    more += o > 2;
  }
  CHECK(overlap2 > 10);
  CHECK(overlap1 > overlap2);
  CHECK(more == 0);
}

TEST_CASE("View renderer: occlusion in voxel mode", "[render][view_renderer]") {
  const Scene& s = scene();
  const ViewRenderer renderer(s.hu, &s.tubes, RendererOptions{});
  const Camerad ap = small_carm(0, 0, 1.0).camera();
  // The far tube's centreline behind the near tube: another passage in front. Breaking the
  // "<= 1" rule (counting its own passage as an occluder, or ignoring the other) flips one of
  // the first two.
  CHECK_FALSE(renderer.unoccluded(ap, {0, -7, 0}));
  CHECK_FALSE(renderer.unoccluded(ap, {-2, -7, 0.5}));
  CHECK(renderer.unoccluded(ap, {0, 7, 0}));    // the near tube itself
  CHECK(renderer.unoccluded(ap, {10, -7, 0}));  // the far tube where nothing is in front
  CHECK(renderer.unoccluded(ap, {0, 0, 12}));   // not behind anything
  // A point on no vessel behind both tubes: two passages in front of it.
  CHECK_FALSE(renderer.unoccluded(ap, {0, -37, 0}));
  // From the side (primary 90: the source on the patient's left, +x) the tubes do not overlap:
  // the ray through the far tube's centreline runs along that tube only.
  const Camerad lateral = small_carm(90, 0, 1.0).camera();
  CHECK(renderer.unoccluded(lateral, {0, -7, 0}));
  CHECK(renderer.unoccluded(lateral, {0, 7, 0}));
}

TEST_CASE("View renderer: mesh mode against voxel mode, and the lumen gain",
          "[render][view_renderer][embree]") {
  const Scene& s = scene();
  const ContrastPreset preset = GENERATE(ContrastPreset::angiography, ContrastPreset::reference);
  const std::shared_ptr<const VesselSurface> surface = vessel_surface_from_mask(s.tubes);
  RendererOptions voxel_options;
  voxel_options.recipe.preset = preset;
  voxel_options.vessel_depth = true;
  RendererOptions mesh_options = voxel_options;
  mesh_options.vessels = VesselMode::mesh;
  const ViewRenderer voxel(s.hu, &s.tubes, voxel_options);
  const ViewRenderer mesh(s.hu, &s.tubes, mesh_options, "volume", nullptr, surface);
  const ViewRenderer plain(s.hu, nullptr, voxel_options);  // no injection at all
  CHECK_FALSE(plain.has_vessels());
  CHECK(mesh.has_vessels());

  // The gain: the tube is 350 HU, dense tissue classified blood. Angiography: iodine at
  // lumen_hu (3000 HU) over native blood (45 HU) at the soft weight; with per-voxel classes
  // (no structure) it would be 0.0706. Reference: 3 mu0 over 0.05 mu0 (the bone add cancels).
  const double mu0 = hu_to_mu(kTubeHu);
  const double gain = preset == ContrastPreset::angiography ? hu_to_mu(3000) - 0.35 * hu_to_mu(45)
                                                            : 3 * mu0 - 0.05 * mu0;
  CHECK(mesh.lumen_gain_per_mm() == Approx(gain).epsilon(1e-6));
  CHECK(voxel.lumen_gain_per_mm() == 0.0);

  for (const Camerad& camera : {small_carm(0, 0, 1.0).camera(), small_carm(40, 20, 1.0).camera()}) {
    const RenderedView v = voxel.render(camera), m = mesh.render(camera), p = plain.render(camera);
    const VesselProjection chord = surface->project(camera);
    int both = 0, either = 0, vessel = 0;
    for (int r = 0; r < camera.rows(); ++r)
      for (int c = 0; c < camera.cols(); ++c) {
        const bool a = v.vessel_mask(r, c) != 0, b = m.vessel_mask(r, c) != 0;
        both += a && b;
        either += a || b;
        INFO("pixel (" << r << ", " << c << ")");
        // The mesh-mode mask, overlap and depth are the surface's.
        REQUIRE(b == (chord.chord_mm(r, c) > 0));
        REQUIRE(m.overlap(r, c) == chord.passages(r, c));
        REQUIRE(m.depth_mm(r, c) == chord.first_hit_mm(r, c));
        // The line integral is the uninjected one plus gain x chord (float sums).
        const double added = m.line_integrals(r, c) - p.line_integrals(r, c);
        if (b) {
          ++vessel;
          REQUIRE(
              added ==
              Approx(mesh.lumen_gain_per_mm() * chord.chord_mm(r, c)).epsilon(1e-4).margin(2e-6));
        } else {
          REQUIRE(added == 0.0);
        }
      }
    REQUIRE(vessel > 100);
    // Measured: mask IoU 0.97 in AP and 0.84 in the oblique view (both presets) on these
    // 2.5 mm tubes at 1 mm voxels, a detector pixel being 0.75 mm at the isocentre: the smoothed
    // surface sits inside the voxel staircase, so the two masks differ on a one-pixel rim,
    // wider where the view sees the staircase obliquely.
    INFO("mask IoU " << static_cast<double>(both) / either);
    CHECK(static_cast<double>(both) / either > 0.8);
    // Overlap: two passages at the crossing in AP, as the voxel mode finds.
    if (camera.R().isApprox(small_carm(0, 0).camera().R())) {
      const auto [r, c] = pixel_of(camera, {0, 0, 0});
      CHECK(m.overlap(r, c) == 2);
      CHECK(v.overlap(r, c) == 2);
      CHECK(m.depth_mm(r, c) == Approx(v.depth_mm(r, c)).margin(1.0));
    }
  }
  // Occlusion through the surface: as in voxel mode.
  const Camerad ap = small_carm(0, 0, 1.0).camera();
  CHECK_FALSE(mesh.unoccluded(ap, {0, -7, 0}));
  CHECK(mesh.unoccluded(ap, {0, 7, 0}));
  CHECK(mesh.unoccluded(ap, {10, -7, 0}));
  CHECK(mesh.unoccluded(ap, {0, 0, 12}));
}

TEST_CASE("View renderer: smoothed voxel steps blur the background only",
          "[render][view_renderer][embree]") {
  // smooth_voxel_steps: the background's line integrals are blurred by half a voxel's footprint
  // (here 1 mm voxels at 0.25 mm pixels: about 5 px, sigma 2.7 px); the vessels are added
  // after, exactly as without it, and their mask, overlap and depth are the surface's.
  const Scene& s = scene();
  const std::shared_ptr<const VesselSurface> surface = vessel_surface_from_mask(s.tubes);
  RendererOptions sharp;
  sharp.vessels = VesselMode::mesh;
  RendererOptions smooth = sharp;
  smooth.smooth_voxel_steps = true;
  const ViewRenderer a(s.hu, &s.tubes, sharp, "volume", nullptr, surface);
  const ViewRenderer b(s.hu, &s.tubes, smooth, "volume", nullptr, surface);
  RendererOptions plain_options;
  const ViewRenderer plain(s.hu, nullptr, plain_options);
  for (const Camerad& camera :
       {small_carm(0, 0, 0.25).camera(), small_carm(30, 20, 0.25).camera()}) {
    // Footprint: one voxel at the volume's centre, across the view (magnification 1000/750).
    const double footprint = b.voxel_footprint_px(camera);
    CHECK(footprint == Approx(1.0 * 1000.0 / 750.0 / 0.25).epsilon(1e-6));
    const RenderedView va = a.render(camera), vb = b.render(camera), vp = plain.render(camera);
    const Image<float> blurred = gaussian_blur(vp.line_integrals, 0.5 * footprint);
    double largest_step_sharp = 0, largest_step_smooth = 0;
    for (int r = 0; r < camera.rows(); ++r)
      for (int c = 0; c < camera.cols(); ++c) {
        INFO("pixel (" << r << ", " << c << ")");
        REQUIRE(vb.vessel_mask(r, c) == va.vessel_mask(r, c));
        REQUIRE(vb.overlap(r, c) == va.overlap(r, c));
        // What the vessels add is the same; the background is the blurred one.
        const double added_sharp = va.line_integrals(r, c) - vp.line_integrals(r, c);
        const double added_smooth = vb.line_integrals(r, c) - blurred(r, c);
        REQUIRE(added_smooth == Approx(added_sharp).margin(2e-5));
        if (c > 0 && !va.vessel_mask(r, c) && !va.vessel_mask(r, c - 1)) {
          largest_step_sharp =
              std::max(largest_step_sharp,
                       std::abs(double(va.line_integrals(r, c)) - va.line_integrals(r, c - 1)));
          largest_step_smooth =
              std::max(largest_step_smooth,
                       std::abs(double(vb.line_integrals(r, c)) - vb.line_integrals(r, c - 1)));
        }
      }
    // The steps between neighbouring background pixels shrink (the bone column's edges).
    CHECK(largest_step_smooth < 0.5 * largest_step_sharp);
  }
}

TEST_CASE("View renderer: bad inputs are refused with the problem named",
          "[render][view_renderer]") {
  const Scene& s = scene();
  RendererOptions mesh_options;
  mesh_options.vessels = VesselMode::mesh;
  // Mesh mode without a surface.
  CHECK_THROWS_AS(ViewRenderer(s.hu, &s.tubes, mesh_options, "patient 7"), Error);
  CHECK_THROWS_WITH(ViewRenderer(s.hu, &s.tubes, mesh_options, "patient 7"),
                    Catch::Contains("patient 7") && Catch::Contains("mesh vessels need a vessel "
                                                                    "surface"));
  // A surface in voxel mode, or without a vessel mask.
  const std::shared_ptr<const VesselSurface> surface = vessel_surface_from_mask(s.tubes);
  CHECK_THROWS_WITH(ViewRenderer(s.hu, &s.tubes, RendererOptions{}, "v", nullptr, surface),
                    Catch::Contains("mesh mode with a vessel mask only"));
  CHECK_THROWS_WITH(ViewRenderer(s.hu, nullptr, mesh_options, "v", nullptr, surface),
                    Catch::Contains("mesh mode with a vessel mask only"));
  // Recipe none (the volume already is attenuation) with a vessel mask.
  RendererOptions none;
  none.recipe.preset = ContrastPreset::none;
  const Volume<float> mu(s.hu.geometry(), 0.01f);
  CHECK_THROWS_WITH(ViewRenderer(mu, &s.tubes, none, "ct"),
                    Catch::Contains("ct") && Catch::Contains("recipe 'none'"));
  // A HU volume with recipe none: attenuation must be >= 0 (air is -1000).
  CHECK_THROWS_WITH(ViewRenderer(s.hu, nullptr, none, "ct"),
                    Catch::Contains("finite and >= 0") && Catch::Contains("-1000"));
  // from_attenuation with a negative or a NaN voxel, named with its value and index.
  Volume<float> bad = mu;
  bad(3, 4, 5) = -0.5f;
  const std::string at = "at voxel " + std::to_string(bad.linear_index(3, 4, 5));
  CHECK_THROWS_WITH(
      ViewRenderer::from_attenuation(bad, RendererOptions{}, "mu"),
      Catch::Contains("mu: attenuation") && Catch::Contains("got -0.5") && Catch::Contains(at));
  bad(3, 4, 5) = std::numeric_limits<float>::quiet_NaN();
  CHECK_THROWS_WITH(ViewRenderer::from_attenuation(bad, RendererOptions{}, "mu"),
                    Catch::Contains("got nan") && Catch::Contains(at));
  bad(3, 4, 5) = std::numeric_limits<float>::infinity();
  CHECK_THROWS_WITH(ViewRenderer::from_attenuation(bad, RendererOptions{}, "mu"),
                    Catch::Contains("got inf"));
  // step_mm NaN or negative, min_chord_mm not positive: named with the value, whatever the mode.
  for (const double step :
       {std::numeric_limits<double>::quiet_NaN(), -1.0, std::numeric_limits<double>::infinity()}) {
    RendererOptions o;
    o.step_mm = step;
    o.projector = Projector::trilinear;
    std::ostringstream value;
    value << "got " << step;
    CHECK_THROWS_WITH(ViewRenderer(s.hu, &s.tubes, o, "v"),
                      Catch::Contains("step_mm must be >= 0") && Catch::Contains(value.str()));
    CHECK_THROWS_WITH(ViewRenderer::from_attenuation(mu, o),
                      Catch::Contains("step_mm must be >= 0") && Catch::Contains(value.str()));
  }
  RendererOptions chord;
  chord.min_chord_mm = 0;
  CHECK_THROWS_WITH(ViewRenderer(s.hu, &s.tubes, chord, "v"),
                    Catch::Contains("min_chord_mm must be > 0, got 0"));
  // The good inputs next to them construct.
  CHECK_NOTHROW(ViewRenderer(s.hu, &s.tubes, mesh_options, "v", nullptr, surface));
  CHECK_NOTHROW(ViewRenderer::from_attenuation(mu, RendererOptions{}));
  CHECK_THROWS_WITH(parse_vessel_mode("meshes"), Catch::Contains("'meshes'"));
  CHECK(parse_vessel_mode(to_string(VesselMode::mesh)) == VesselMode::mesh);
}
