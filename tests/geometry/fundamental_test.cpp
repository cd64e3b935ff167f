// Fundamental-matrix estimation: the weighted normalised 8-point, the affine Gold Standard and
// MSAC. Bad input throws gimm::Error; degenerate input returns std::nullopt.
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>

#include "gimm/geometry/fundamental.hpp"
#include "scene.hpp"

using namespace gimm;
using Catch::Matchers::Contains;
using gimm_test::carm_pose;

namespace {

/// Points along one image line in each image: every bilinear monomial is then a quadratic in
/// the line parameter, so the 8-point system has rank <= 3.
void collinear(Points2<double>& x_a, Points2<double>& x_b, int n, std::uint64_t seed) {
  Rng rng(seed);
  x_a.resize(2, n);
  x_b.resize(2, n);
  for (int i = 0; i < n; ++i) {
    const double t = rng.uniform(-50, 50);
    x_a.col(i) = Eigen::Vector2d(200 + 3 * t, 150 + 2 * t);
    x_b.col(i) = Eigen::Vector2d(260 - t, 240 + 4 * t);
  }
}

/// Replaces the first `outliers` correspondences' x_b by random pixels at least 5 px (Sampson)
/// from their true epipolar geometry; returns the true inlier mask.
std::vector<char> contaminate(Points2<double>& x_a, Points2<double>& x_b, const Eigen::Matrix3d& F,
                              int outliers, std::uint64_t seed) {
  Rng rng(seed);
  std::vector<char> inlier(static_cast<std::size_t>(x_a.cols()), 1);
  for (int i = 0; i < outliers; ++i) {
    Eigen::Vector2d candidate;
    do {
      candidate = Eigen::Vector2d(rng.uniform(0, 511), rng.uniform(0, 511));
    } while (sampson_distance_sq<double>(F, x_a.col(i), candidate) < 25);
    x_b.col(i) = candidate;
    inlier[static_cast<std::size_t>(i)] = 0;
  }
  return inlier;
}

}  // namespace

TEST_CASE("fundamental_8pt recovers F from noise-free C-arm pairs", "[geometry][fundamental]") {
  const double primary_b = GENERATE(-90.0, -30.0, 40.0);
  const double secondary_b = GENERATE(-25.0, 30.0);
  const Camerad a = carm_pose(20, 10).camera();
  const Camerad b = carm_pose(primary_b, secondary_b).camera();
  const Eigen::Matrix3d F_true = fundamental_from_cameras(a, b);
  const int n = GENERATE(8, 9, 50);
  const auto scene = gimm_test::make_pair_scene(a, b, n, 100 + static_cast<std::uint64_t>(n));
  const auto F = fundamental_8pt<double>(scene.x_a, scene.x_b);
  REQUIRE(F);
  // Both are in canonical form (unit norm, largest entry positive), so they compare directly.
  CHECK((*F - F_true).norm() < 1e-6);
  CHECK(gimm_test::max_symmetric_sq(*F, scene.x_a, scene.x_b) < 1e-10);
  CHECK(F->norm() == Approx(1));
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(*F);
  CHECK(svd.singularValues()(2) < 1e-12);  // rank 2 enforced
  // Correspondences swapped give the transpose.
  const auto F_ba = fundamental_8pt<double>(scene.x_b, scene.x_a);
  REQUIRE(F_ba);
  CHECK((*F_ba - normalize_fundamental(Eigen::Matrix3d(F->transpose()))).norm() < 1e-6);
}

TEST_CASE("fundamental_8pt weights", "[geometry][fundamental]") {
  const Camerad a = carm_pose(30, 20).camera(), b = carm_pose(-30, -15).camera();
  const Eigen::Matrix3d F_true = fundamental_from_cameras(a, b);
  auto scene = gimm_test::make_pair_scene(a, b, 40, 9);
  Rng noise(4);
  for (Eigen::Index i = 0; i < scene.x_b.cols(); ++i)
    scene.x_b.col(i) += Eigen::Vector2d(noise.normal(0, 0.3), noise.normal(0, 0.3));
  const auto unweighted = fundamental_8pt<double>(scene.x_a, scene.x_b);
  REQUIRE(unweighted);

  SECTION("all ones equals unweighted") {
    const auto ones = fundamental_8pt<double>(scene.x_a, scene.x_b, VectorX<double>::Ones(40));
    REQUIRE(ones);
    CHECK((*ones - *unweighted).norm() == 0);
  }
  SECTION("a common scale of the weights changes nothing") {
    const auto scaled =
        fundamental_8pt<double>(scene.x_a, scene.x_b, VectorX<double>::Constant(40, 3.75));
    REQUIRE(scaled);
    CHECK((*scaled - *unweighted).norm() < 1e-10);
  }
  SECTION("weight 2 counts like the correspondence twice (W = diag(sqrt(w)) on the rows)") {
    VectorX<double> w = VectorX<double>::Ones(40);
    w(3) = 2;
    w(17) = 3;
    Points2<double> xa(2, 43), xb(2, 43);
    xa << scene.x_a, scene.x_a.col(3), scene.x_a.col(17), scene.x_a.col(17);
    xb << scene.x_b, scene.x_b.col(3), scene.x_b.col(17), scene.x_b.col(17);
    const auto weighted = fundamental_8pt<double>(scene.x_a, scene.x_b, w);
    const auto repeated = fundamental_8pt<double>(xa, xb);
    REQUIRE(weighted);
    REQUIRE(repeated);
    CHECK((*weighted - *repeated).norm() < 1e-10);
    CHECK((*weighted - *unweighted).norm() > 1e-6);
  }
  SECTION("rank 2 is enforced on noisy data") {
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(*unweighted);
    CHECK(svd.singularValues()(2) < 1e-12 * svd.singularValues()(0));
    CHECK((*unweighted - F_true).norm() > 1e-6);  // the noise is visible...
    CHECK((*unweighted - F_true).norm() < 1e-1);  // ...but small
  }
  SECTION("non-uniform weights change the estimate") {
    VectorX<double> w = VectorX<double>::Ones(40);
    for (int i = 0; i < 20; ++i) w(i) = 0.05;
    const auto weighted = fundamental_8pt<double>(scene.x_a, scene.x_b, w);
    REQUIRE(weighted);
    CHECK((*weighted - *unweighted).norm() > 1e-6);
  }
  SECTION("a zero weight removes an outlier's influence") {
    Points2<double> xa(2, 41), xb(2, 41);
    xa << scene.x_a, Eigen::Vector2d(100, 100);
    xb << scene.x_b, Eigen::Vector2d(400, 30);  // far off its epipolar line
    REQUIRE(symmetric_epipolar_distance_sq<double>(F_true, xa.col(40), xb.col(40)) > 1e3);
    const auto polluted = fundamental_8pt<double>(xa, xb);
    REQUIRE(polluted);
    CHECK((*polluted - *unweighted).norm() > 1e-4);
    VectorX<double> w = VectorX<double>::Ones(41);
    w(40) = 0;
    const auto cleaned = fundamental_8pt<double>(xa, xb, w);
    REQUIRE(cleaned);
    CHECK((*cleaned - *unweighted).norm() < 1e-10);
  }
  SECTION("noise-free data: any positive weights give the exact F") {
    const auto exact = gimm_test::make_pair_scene(a, b, 30, 12);
    VectorX<double> w(30);
    Rng rng(8);
    for (int i = 0; i < 30; ++i) w(i) = rng.uniform(0.1, 1.0);
    const auto F = fundamental_8pt<double>(exact.x_a, exact.x_b, w);
    REQUIRE(F);
    CHECK((*F - F_true).norm() < 1e-6);
  }
}

TEST_CASE("fundamental_8pt invalid input throws gimm::Error", "[geometry][fundamental]") {
  const Camerad a = carm_pose(30, 20).camera(), b = carm_pose(-30, -15).camera();
  const auto scene = gimm_test::make_pair_scene(a, b, 12, 5);
  const Points2<double> seven_a = scene.x_a.leftCols(7), seven_b = scene.x_b.leftCols(7);
  CHECK_THROWS_WITH(fundamental_8pt<double>(seven_a, seven_b),
                    Contains("fundamental_8pt") && Contains("at least 8") && Contains("got 7"));
  CHECK_THROWS_WITH(fundamental_8pt<double>(scene.x_a, Points2<double>(scene.x_b.leftCols(11))),
                    Contains("12 points") && Contains("11"));
  Points2<double> nan_a = scene.x_a;
  nan_a(1, 4) = std::numeric_limits<double>::quiet_NaN();
  CHECK_THROWS_WITH(fundamental_8pt<double>(nan_a, scene.x_b),
                    Contains("correspondence 4") && Contains("non-finite"));
  Points2<double> inf_b = scene.x_b;
  inf_b(0, 2) = std::numeric_limits<double>::infinity();
  CHECK_THROWS_AS(fundamental_8pt<double>(scene.x_a, inf_b), Error);
  VectorX<double> w = VectorX<double>::Ones(12);
  w(3) = -0.5;
  CHECK_THROWS_WITH(fundamental_8pt<double>(scene.x_a, scene.x_b, w),
                    Contains("weight 3") && Contains("-0.5"));
  w(3) = std::numeric_limits<double>::quiet_NaN();
  CHECK_THROWS_WITH(fundamental_8pt<double>(scene.x_a, scene.x_b, w), Contains("weight 3"));
  w(3) = std::numeric_limits<double>::infinity();
  CHECK_THROWS_AS(fundamental_8pt<double>(scene.x_a, scene.x_b, w), Error);
  CHECK_THROWS_WITH(fundamental_8pt<double>(scene.x_a, scene.x_b, VectorX<double>::Ones(5)),
                    Contains("5 weights for 12 points"));
}

TEST_CASE("fundamental_8pt degenerate configurations return nullopt", "[geometry][fundamental]") {
  const Camerad a = carm_pose(30, 20).camera(), b = carm_pose(-30, -15).camera();
  const auto scene = gimm_test::make_pair_scene(a, b, 12, 5);
  SECTION("fewer than 8 positive weights") {
    VectorX<double> w = VectorX<double>::Ones(12);
    w.head(5).setZero();
    CHECK_FALSE(fundamental_8pt<double>(scene.x_a, scene.x_b, w));
    w(0) = 1e-3;  // 8 positive: a solution
    CHECK(fundamental_8pt<double>(scene.x_a, scene.x_b, w));
    CHECK_FALSE(fundamental_8pt<double>(scene.x_a, scene.x_b, VectorX<double>::Zero(12)));
  }
  SECTION("all points of one image coincident") {
    Points2<double> same = scene.x_a;
    same.colwise() = Eigen::Vector2d(250, 260);
    CHECK_FALSE(fundamental_8pt<double>(same, scene.x_b));
    CHECK_FALSE(fundamental_8pt<double>(scene.x_a, same));
    // Coincident among the positively weighted points only.
    Points2<double> mostly = scene.x_a;
    mostly.leftCols(10).colwise() = Eigen::Vector2d(250, 260);
    VectorX<double> w = VectorX<double>::Ones(12);
    w(10) = 0;
    w(11) = 0;
    CHECK_FALSE(fundamental_8pt<double>(mostly, scene.x_b, w));
  }
  SECTION("collinear points: the solution is not unique") {
    Points2<double> xa, xb;
    collinear(xa, xb, 20, 3);
    CHECK_FALSE(fundamental_8pt<double>(xa, xb));
  }
  SECTION("a repeated correspondence counts once: 8 columns, 7 distinct") {
    Points2<double> xa = scene.x_a.leftCols(8), xb = scene.x_b.leftCols(8);
    xa.col(7) = xa.col(0);
    xb.col(7) = xb.col(0);
    CHECK_FALSE(fundamental_8pt<double>(xa, xb));
  }
}

TEST_CASE("fundamental_8pt_minimal is fundamental_8pt on 8 points, faster",
          "[geometry][fundamental]") {
  // The fast path (LU on the 8 x 9 system) against the slow one (the 9 x 9 eigensolver) on
  // RANSAC's minimal samples: noisy and contaminated, from several C-arm pairs.
  int compared = 0;
  for (std::uint64_t seed = 0; seed < 20; ++seed) {
    const Camerad a = carm_pose(-40 + 4.0 * seed, 25).camera(), b = carm_pose(35, -20).camera();
    auto scene = gimm_test::make_pair_scene(a, b, 80, seed);
    Rng rng(seed + 100);
    for (Eigen::Index i = 0; i < scene.x_a.cols(); ++i)
      scene.x_b.col(i) += Eigen::Vector2d(rng.normal(0, 0.5), rng.normal(0, 0.5));
    contaminate(scene.x_a, scene.x_b, fundamental_from_cameras(a, b), 16, seed);
    for (int s = 0; s < 10; ++s) {
      const Points2<double> xa = scene.x_a.middleCols(8 * s, 8),
                            xb = scene.x_b.middleCols(8 * s, 8);
      const auto slow = fundamental_8pt<double>(xa, xb),
                 fast = fundamental_8pt_minimal<double>(xa, xb);
      REQUIRE(slow.has_value() == fast.has_value());
      if (!slow) continue;
      CHECK((*fast - *slow).norm() < 1e-8);
      ++compared;
    }
  }
  CHECK(compared == 200);
  // Degenerate samples: no F from either.
  Points2<double> xa, xb;
  collinear(xa, xb, 8, 3);
  CHECK_FALSE(fundamental_8pt_minimal<double>(xa, xb));
  const auto scene =
      gimm_test::make_pair_scene(carm_pose(30, 20).camera(), carm_pose(-30, -15).camera(), 8, 5);
  Points2<double> repeated_a = scene.x_a, repeated_b = scene.x_b;
  repeated_a.col(7) = repeated_a.col(0);
  repeated_b.col(7) = repeated_b.col(0);
  CHECK_FALSE(fundamental_8pt_minimal<double>(repeated_a, repeated_b));
  CHECK_FALSE(fundamental_8pt<double>(repeated_a, repeated_b));
  CHECK_THROWS_WITH(fundamental_8pt_minimal<double>(scene.x_a.leftCols(7), scene.x_b.leftCols(7)),
                    Contains("exactly 8"));
}

TEST_CASE("fundamental_affine recovers the affine F of orthographic pairs",
          "[geometry][fundamental]") {
  const double primary_b = GENERATE(-60.0, 35.0);
  const Camerad a = carm_pose(10, 25, ProjectionModel::orthographic).camera();
  const Camerad b = carm_pose(primary_b, -20, ProjectionModel::orthographic).camera();
  const Eigen::Matrix3d F_true = fundamental_from_cameras(a, b);
  const int n = GENERATE(4, 5, 60);
  const auto scene = gimm_test::make_pair_scene(a, b, n, 40 + static_cast<std::uint64_t>(n));
  const auto F = fundamental_affine<double>(scene.x_a, scene.x_b);
  REQUIRE(F);
  CHECK(F->topLeftCorner<2, 2>().norm() == 0);  // affine by construction
  CHECK((*F - F_true).norm() < 1e-9);
  CHECK(gimm_test::max_symmetric_sq(*F, scene.x_a, scene.x_b) < 1e-12);
  const auto ones = fundamental_affine<double>(scene.x_a, scene.x_b, VectorX<double>::Ones(n));
  REQUIRE(ones);
  CHECK((*ones - *F).norm() == 0);
}

TEST_CASE("fundamental_affine weights, bad and degenerate input", "[geometry][fundamental]") {
  const Camerad a = carm_pose(10, 25, ProjectionModel::orthographic).camera();
  const Camerad b = carm_pose(-50, -20, ProjectionModel::orthographic).camera();
  const Eigen::Matrix3d F_true = fundamental_from_cameras(a, b);
  const auto scene = gimm_test::make_pair_scene(a, b, 20, 6);
  SECTION("a zero weight removes an outlier") {
    Points2<double> xa(2, 21), xb(2, 21);
    xa << scene.x_a, Eigen::Vector2d(100, 100);
    xb << scene.x_b, Eigen::Vector2d(400, 30);
    const auto polluted = fundamental_affine<double>(xa, xb);
    REQUIRE(polluted);
    CHECK((*polluted - F_true).norm() > 1e-4);
    VectorX<double> w = VectorX<double>::Ones(21);
    w(20) = 0;
    const auto cleaned = fundamental_affine<double>(xa, xb, w);
    REQUIRE(cleaned);
    CHECK((*cleaned - F_true).norm() < 1e-9);
  }
  SECTION("invalid input throws") {
    CHECK_THROWS_WITH(fundamental_affine<double>(Points2<double>(scene.x_a.leftCols(3)),
                                                 Points2<double>(scene.x_b.leftCols(3))),
                      Contains("fundamental_affine") && Contains("at least 4"));
    VectorX<double> w = VectorX<double>::Ones(20);
    w(7) = -1;
    CHECK_THROWS_WITH(fundamental_affine<double>(scene.x_a, scene.x_b, w), Contains("weight 7"));
    Points2<double> nan_b = scene.x_b;
    nan_b(0, 0) = std::numeric_limits<double>::quiet_NaN();
    CHECK_THROWS_AS(fundamental_affine<double>(scene.x_a, nan_b), Error);
  }
  SECTION("degenerate input returns nullopt") {
    VectorX<double> w = VectorX<double>::Zero(20);
    w.head(3).setOnes();
    CHECK_FALSE(fundamental_affine<double>(scene.x_a, scene.x_b, w));  // 3 positive weights
    // All x_b on one line, x_a spread: a constraint on image B alone is no epipolar geometry.
    Points2<double> line_b = scene.x_b;
    for (Eigen::Index i = 0; i < 20; ++i) line_b(1, i) = 0.5 * line_b(0, i) + 30;
    CHECK_FALSE(fundamental_affine<double>(scene.x_a, line_b));
    // Collinear in both images: not unique.
    Points2<double> xa, xb;
    collinear(xa, xb, 20, 8);
    CHECK_FALSE(fundamental_affine<double>(xa, xb));
  }
}

TEST_CASE("estimate_fundamental_ransac finds the inliers among 30% outliers",
          "[geometry][fundamental]") {
  const bool affine = GENERATE(false, true);
  const auto model = affine ? ProjectionModel::orthographic : ProjectionModel::perspective;
  const Camerad a = carm_pose(30, 20, model).camera(), b = carm_pose(-30, -15, model).camera();
  const Eigen::Matrix3d F_true = fundamental_from_cameras(a, b);
  auto scene = gimm_test::make_pair_scene(a, b, 100, 21);
  const auto truth = contaminate(scene.x_a, scene.x_b, F_true, 30, 22);

  RansacOptions options;
  options.model = affine ? FundamentalModel::affine : FundamentalModel::perspective;
  options.seed = 1234;
  const auto result = estimate_fundamental_ransac<double>(scene.x_a, scene.x_b, options);
  REQUIRE(result.F);
  CHECK(result.inliers == truth);
  CHECK(result.stats.num_inliers == 70);
  CHECK(result.stats.inlier_ratio == Approx(0.7));
  CHECK(result.stats.iterations >= options.min_iterations);
  CHECK(result.stats.iterations <= options.max_iterations);
  CHECK((*result.F - F_true).norm() < 1e-6);
  if (affine) CHECK(result.F->topLeftCorner<2, 2>().norm() == 0);

  // Deterministic: the same seed gives the same bits.
  const auto again = estimate_fundamental_ransac<double>(scene.x_a, scene.x_b, options);
  REQUIRE(again.F);
  CHECK((*again.F - *result.F).norm() == 0);
  CHECK(again.inliers == result.inliers);
  CHECK(again.stats.iterations == result.stats.iterations);
  CHECK(again.stats.score == result.stats.score);
  // Another seed, another path, the same answer; the symmetric distance works too.
  options.seed = 99;
  options.distance = EpipolarDistance::symmetric;
  const auto other = estimate_fundamental_ransac<double>(scene.x_a, scene.x_b, options);
  REQUIRE(other.F);
  CHECK(other.inliers == truth);
  CHECK((*other.F - F_true).norm() < 1e-6);
}

TEST_CASE("estimate_fundamental_ransac: sampled local optimisation finds what the full one does",
          "[geometry][fundamental]") {
  // 400 correspondences, 25% outliers: refitting on 64 sampled inliers (the default) or on all
  // of them (0) gives the same inliers, and the final refit on all keeps the F as close.
  const Camerad a = carm_pose(-35, 20).camera(), b = carm_pose(40, -10).camera();
  auto scene = gimm_test::make_pair_scene(a, b, 400, 21);
  Rng rng(4);
  for (Eigen::Index i = 0; i < scene.x_a.cols(); ++i)
    scene.x_b.col(i) += Eigen::Vector2d(rng.normal(0, 0.5), rng.normal(0, 0.5));
  const Eigen::Matrix3d F_true = fundamental_from_cameras(a, b);
  const auto inlier = contaminate(scene.x_a, scene.x_b, F_true, 100, 9);
  RansacOptions sampled;
  sampled.threshold_px = 1.5;
  RansacOptions full = sampled;
  full.local_optimization_sample = 0;
  const auto rs = estimate_fundamental_ransac<double>(scene.x_a, scene.x_b, sampled);
  const auto rf = estimate_fundamental_ransac<double>(scene.x_a, scene.x_b, full);
  REQUIRE(rs.F);
  REQUIRE(rf.F);
  CHECK(rs.inliers == rf.inliers);
  std::size_t right = 0;
  for (std::size_t i = 0; i < inlier.size(); ++i) right += rs.inliers[i] == inlier[i];
  CHECK(right >= 390);
  CHECK((*rs.F - *rf.F).norm() < 1e-9);
}

TEST_CASE("estimate_fundamental_ransac with noisy inliers", "[geometry][fundamental]") {
  const Camerad a = carm_pose(40, 0).camera(), b = carm_pose(-20, 25).camera();
  const Eigen::Matrix3d F_true = fundamental_from_cameras(a, b);
  auto scene = gimm_test::make_pair_scene(a, b, 150, 31);
  Rng noise(32);
  for (Eigen::Index i = 0; i < 150; ++i) {
    scene.x_a.col(i) += Eigen::Vector2d(noise.normal(0, 0.2), noise.normal(0, 0.2));
    scene.x_b.col(i) += Eigen::Vector2d(noise.normal(0, 0.2), noise.normal(0, 0.2));
  }
  const auto truth = contaminate(scene.x_a, scene.x_b, F_true, 45, 33);
  RansacOptions options;
  options.threshold_px = 1.5;
  options.seed = 5;
  const auto result = estimate_fundamental_ransac<double>(scene.x_a, scene.x_b, options);
  REQUIRE(result.F);
  int false_inliers = 0, missed = 0;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    false_inliers += result.inliers[i] && !truth[i];
    missed += !result.inliers[i] && truth[i];
  }
  CHECK(false_inliers == 0);
  CHECK(missed <= 3);
  // The estimate fits the clean inliers to within the noise.
  double worst = 0;
  for (Eigen::Index i = 45; i < 150; ++i)
    worst =
        std::max(worst, sampson_distance_sq<double>(*result.F, scene.x_a.col(i), scene.x_b.col(i)));
  CHECK(worst < 1.5 * 1.5 * 2);
}

TEST_CASE("estimate_fundamental_ransac invalid options throw", "[geometry][fundamental]") {
  const Camerad a = carm_pose(30, 20).camera(), b = carm_pose(-30, -15).camera();
  const auto scene = gimm_test::make_pair_scene(a, b, 20, 5);
  RansacOptions options;
  options.threshold_px = 0;
  CHECK_THROWS_WITH(estimate_fundamental_ransac<double>(scene.x_a, scene.x_b, options),
                    Contains("threshold_px") && Contains("got 0"));
  options = {};
  options.confidence = 1.0;
  CHECK_THROWS_WITH(estimate_fundamental_ransac<double>(scene.x_a, scene.x_b, options),
                    Contains("confidence"));
  options = {};
  options.max_iterations = 0;
  CHECK_THROWS_AS(estimate_fundamental_ransac<double>(scene.x_a, scene.x_b, options), Error);
  options = {};  // a count that would run for years, and a minimum above the maximum
  options.max_iterations = std::int64_t(1) << 62;
  CHECK_THROWS_WITH(estimate_fundamental_ransac<double>(scene.x_a, scene.x_b, options),
                    Contains("max_iterations <= 100000000") && Contains("4611686018427387904"));
  options = {};
  options.min_iterations = std::int64_t(1) << 62;
  CHECK_THROWS_WITH(estimate_fundamental_ransac<double>(scene.x_a, scene.x_b, options),
                    Contains("min_iterations <= max_iterations"));
  options = {};
  options.local_optimization_sample = -1;
  CHECK_THROWS_WITH(estimate_fundamental_ransac<double>(scene.x_a, scene.x_b, options),
                    Contains("local_optimization_sample must be >= 0") && Contains("-1"));
  options = {};
  CHECK_THROWS_WITH(
      estimate_fundamental_ransac<double>(Points2<double>(scene.x_a.leftCols(7)),
                                          Points2<double>(scene.x_b.leftCols(7)), options),
      Contains("at least 8"));
  options.model = FundamentalModel::affine;  // 4 suffice for the affine solver
  CHECK_NOTHROW(estimate_fundamental_ransac<double>(
      Points2<double>(scene.x_a.leftCols(7)), Points2<double>(scene.x_b.leftCols(7)), options));
}

TEST_CASE("estimate_fundamental_ransac on degenerate data returns no F",
          "[geometry][fundamental]") {
  Points2<double> xa, xb;
  collinear(xa, xb, 30, 2);
  const auto result = estimate_fundamental_ransac<double>(xa, xb);
  CHECK_FALSE(result.F);
  CHECK(result.stats.degenerate_samples == result.stats.iterations);
  CHECK(result.stats.num_inliers == 0);
  CHECK(std::count(result.inliers.begin(), result.inliers.end(), 1) == 0);
}
