// The DRR renderer: conventions (where things land), determinism, recipes.
#include <catch2/catch.hpp>
#include <cmath>
#include <vector>

#include "gimm/anatomy/attenuation.hpp"
#include "gimm/core/parallel.hpp"
#include "gimm/core/rng.hpp"
#include "gimm/geometry/carm.hpp"
#include "gimm/render/drr.hpp"

#ifdef _OPENMP
#include <omp.h>
#endif

using namespace gimm;

namespace {

/// 64^3 volume of 1 mm voxels centred on the world origin holding a Gaussian blob (sigma
/// 1.5 mm) centred on `world`. Smooth on purpose: a sharp-edged marker sampled at pixel centres
/// biases the image centroid by up to half a pixel whenever an edge falls on a sample.
Volume<float> marker_volume(const Eigen::Vector3d& world) {
  VolumeGeometry g;
  g.dims = {64, 64, 64};
  g.origin = Eigen::Vector3d::Constant(-31.5);
  Volume<float> v(g, 0.0f);
  for (int k = 0; k < 64; ++k)
    for (int j = 0; j < 64; ++j)
      for (int i = 0; i < 64; ++i) {
        const double r2 = (v.index_to_world(Eigen::Vector3d(i, j, k)) - world).squaredNorm();
        if (r2 < 36) v(i, j, k) = static_cast<float>(std::exp(-r2 / (2 * 1.5 * 1.5)));
      }
  return v;
}

/// Intensity-weighted centroid (u, v) of an image.
Eigen::Vector2d centroid(const Image<float>& image) {
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  double total = 0;
  for (int r = 0; r < image.rows(); ++r)
    for (int c = 0; c < image.cols(); ++c) {
      sum += image(r, c) * Eigen::Vector2d(c, r);
      total += image(r, c);
    }
  REQUIRE(total > 0);
  return sum / total;
}

CArm small_carm(double primary, double secondary, ProjectionModel model) {
  CArm carm;
  carm.primary_deg = primary;
  carm.secondary_deg = secondary;
  carm.rows = 96;
  carm.cols = 128;
  carm.pixel_mm = 1.0;
  carm.model = model;
  return carm;
}

}  // namespace

TEST_CASE("DRR: a marker lands where the camera projects it", "[render][drr]") {
  const auto model = GENERATE(ProjectionModel::perspective, ProjectionModel::orthographic);
  const auto projector = GENERATE(Projector::siddon, Projector::trilinear);
  const Eigen::Vector3d marker(12.3, -7.1, 8.6);  // left, anterior, towards the head
  const Volume<float> v = marker_volume(marker);
  for (const auto& [primary, secondary] :
       std::vector<std::pair<double, double>>{{0, 0}, {40, 20}, {-30, -25}, {90, 0}}) {
    const Camerad camera = small_carm(primary, secondary, model).camera();
    DrrOptions options;
    options.projector = projector;
    options.step_mm = 0.25;
    const Image<float> drr = render_line_integrals(v, camera, options);
    const Eigen::Vector2d expected = camera.project(marker).uv;
    // The projected blob's centroid sits on the projected centre to a small fraction of a pixel
    // (perspective moves it by a few thousandths).
    CHECK((centroid(drr) - expected).norm() < 0.1);
  }
}

TEST_CASE("DRR: in AP, the patient's left is on the image's right and the head at the top",
          "[render][drr]") {
  const Camerad camera = small_carm(0, 0, ProjectionModel::perspective).camera();
  const Image<float> left = render_line_integrals(marker_volume({15, 0, 0}), camera);
  const Image<float> head = render_line_integrals(marker_volume({0, 0, 15}), camera);
  CHECK(centroid(left).x() > (camera.cols() - 1) / 2.0 + 10);
  CHECK(centroid(head).y() < (camera.rows() - 1) / 2.0 - 10);
}

TEST_CASE("DRR: a uniform slab gives its analytic optical depth on the central ray",
          "[render][drr]") {
  VolumeGeometry g;
  g.dims = {40, 40, 40};
  g.spacing = {0.5, 0.5, 0.5};
  g.origin = Eigen::Vector3d::Constant(-9.75);
  const Volume<float> v(g, 0.02f);  // water, 20 mm thick along y
  const Camerad camera = small_carm(0, 0, ProjectionModel::perspective).camera();
  const Image<float> drr = render_line_integrals(v, camera);
  // The central ray (through the isocentre) runs along -y: 20 mm of mu = 0.02 -> 0.4. The
  // principal point is at (63.5, 47.5): average the four pixels around it (each off-axis
  // by 0.5 px, a negligible obliquity).
  const double centre = 0.25 * (drr(47, 63) + drr(47, 64) + drr(48, 63) + drr(48, 64));
  CHECK(centre == Approx(0.4).epsilon(1e-4));
  const Image<float> intensity = beer_lambert(drr);
  CHECK(intensity(47, 63) == Approx(std::exp(-drr(47, 63))));
}

TEST_CASE("DRR: identical on any thread count", "[render][drr]") {
  VolumeGeometry g;
  g.dims = {48, 40, 36};
  g.spacing = {0.8, 0.9, 1.1};
  g.origin = Eigen::Vector3d(-19, -17, -19);
  Volume<float> v(g);
  std::uint32_t state = 12345;
  for (auto& x : v.storage()) {
    state = state * 1664525u + 1013904223u;
    x = static_cast<float>(state >> 8) / 16777216.0f * 0.05f;
  }
  const Camerad camera = small_carm(35, -20, ProjectionModel::perspective).camera();
  for (const auto projector : {Projector::siddon, Projector::trilinear}) {
    DrrOptions options;
    options.projector = projector;
#ifdef _OPENMP
    const int saved = omp_get_max_threads();
    omp_set_num_threads(1);
    const Image<float> one = render_line_integrals(v, camera, options);
    omp_set_num_threads(2);
    const Image<float> two = render_line_integrals(v, camera, options);
    omp_set_num_threads(saved);
    CHECK(one.storage() == two.storage());
#endif
  }
}

TEST_CASE("Attenuation: the reference recipe, voxel by voxel", "[render][recipe]") {
  ContrastRecipe recipe;
  recipe.preset = ContrastPreset::reference;
  const double mw = kMuWaterPerMm;
  CHECK(hu_to_mu(-1000) == 0.0);
  CHECK(hu_to_mu(-1500) == 0.0);  // clipped at 0
  CHECK(hu_to_mu(0) == Approx(mw));
  CHECK(recipe.mu(-500, false) == Approx(0.5 * mw));        // lung: below -100, unchanged
  CHECK(recipe.mu(50, false) == Approx(0.05 * 1.05 * mw));  // soft tissue x 0.05
  CHECK(recipe.mu(400, true) == Approx(3 * 1.4 * mw + 0.1 * 1.4 * mw));   // mu + 2 mu + bone term
  CHECK(recipe.mu(1000, false) == Approx(0.05 * 2 * mw + 0.1 * 2 * mw));  // bone: soft + bone term
  CHECK(recipe.mu(50, true) == Approx(3 * 1.05 * mw));
}

TEST_CASE("Attenuation: the reference preset equals the reference's own computation",
          "[render][recipe]") {
  // The released generator computes, over whole arrays (project_ct_drr_orthographic_selective
  // with its DRR_PARAMS: blood_hu_thresh -100, blood_suppress_factor 0.05, coronary_boost 2,
  // bone_hu_thresh 200, bone_weight 0.10, mu_water 0.02):
  //   mu = clip(0.02 (1 + HU / 1000), 0);  bg = mu; bg[(HU > -100) & ~cor] *= 0.05
  //   mu_eff = bg + 2 * mu * cor + 0.10 * mu * (HU > 200)
  // Written here step by step on a small volume covering every branch and the thresholds.
  VolumeGeometry g;
  g.dims = {6, 5, 4};
  Volume<float> hu(g);
  Volume<std::uint8_t> cor(g, 0);
  Rng rng(41);
  const float edges[] = {-1000, -100, 200, -100.5f, 200.5f, -1200};
  for (std::size_t n = 0; n < hu.size(); ++n) {
    hu.data()[n] = n < 6 ? edges[n] : static_cast<float>(rng.uniform(-1100, 1600));
    cor.data()[n] = rng.uniform() < 0.4;
  }
  const std::size_t n_voxels = hu.size();
  std::vector<double> mu(n_voxels), bg(n_voxels), expected(n_voxels);
  for (std::size_t n = 0; n < n_voxels; ++n)
    mu[n] = std::max(0.0, 0.02 * (1 + hu.data()[n] / 1000.0));
  for (std::size_t n = 0; n < n_voxels; ++n)
    bg[n] = (hu.data()[n] > -100 && !cor.data()[n]) ? mu[n] * 0.05 : mu[n];
  for (std::size_t n = 0; n < n_voxels; ++n)
    expected[n] = bg[n] + 2 * mu[n] * cor.data()[n] + 0.10 * mu[n] * (hu.data()[n] > 200);
  ContrastRecipe recipe;
  recipe.preset = ContrastPreset::reference;
  const Volume<float> got = make_attenuation(hu, &cor, recipe);
  for (std::size_t n = 0; n < n_voxels; ++n) {
    INFO("voxel " << n << ": HU " << hu.data()[n] << ", coronary " << int(cor.data()[n]));
    REQUIRE(got.data()[n] == Approx(expected[n]).epsilon(1e-6));
  }
}

TEST_CASE("Attenuation: the angiography recipe suppresses the blood pool, keeps bone",
          "[render][recipe]") {
  ContrastRecipe recipe;                                         // angiography is the default
  CHECK(recipe.mu(400, true) > 3 * recipe.mu(400, false));       // injected lumen stands out
  CHECK(recipe.mu(400, false) == Approx(recipe.mu(45, false)));  // enhanced blood -> native
  CHECK(recipe.mu(1000, false) == Approx(hu_to_mu(1000)));       // bone at full weight
  CHECK(recipe.mu(40, false) < 0.5 * hu_to_mu(40));              // soft tissue faint

  VolumeGeometry g;
  g.dims = {2, 1, 1};
  Volume<float> hu(g, 0.0f);
  hu(1, 0, 0) = std::nanf("");
  CHECK_THROWS_WITH(make_attenuation<std::uint8_t>(hu, nullptr, recipe, "ct.nii"),
                    Catch::Contains("ct.nii") && Catch::Contains("not finite"));
  Volume<std::uint8_t> wrong_grid(VolumeGeometry{{3, 1, 1}}, 0);
  hu(1, 0, 0) = 0;
  CHECK_THROWS_WITH(make_attenuation(hu, &wrong_grid, recipe, "ct.nii"),
                    Catch::Contains("label grid 3x1x1"));
}
