// Geometry: fundamental-matrix estimation and projection, single thread.
// - 8-point (unweighted and weighted) for N = 8, 64, 256, 1024 correspondences at 0.5 px noise.
// - MSAC + local optimisation (estimate_fundamental_ransac) at 0.5 px noise and 20% outliers.
// - OpenCV findFundamentalMat (FM_8POINT, FM_RANSAC, and USAC_ACCURATE for reference) on the
//   very same point sets, when built with OpenCV (GIMM_HAVE_OPENCV).
// - Camera::project of 10^6 points (perspective and orthographic), P x batch, cv::projectPoints.
// Counter epi_px: mean sqrt(symmetric_epipolar_distance_sq) of the noise-free correspondences
// under the estimated F (px). Scenes: benchmarks/geometry_scenes.hpp. Accuracy tables:
// gimm_geometry_accuracy_bench.
#include <benchmark/benchmark.h>

#include <map>
#include <tuple>
#include <vector>

#include "geometry_scenes.hpp"

namespace {

using gimm_bench::Scene;
using gimm_bench::SceneOptions;

constexpr double kNoisePx = 0.5;
constexpr double kOutliers = 0.2;
constexpr double kThresholdPx = 1.5;  // 3 sigma, for both gimm and OpenCV RANSAC

/// One scene per (N, outlier fraction, model), built once and shared by gimm and OpenCV cases.
const Scene& scene(int n, double outliers,
                   gimm::ProjectionModel model = gimm::ProjectionModel::perspective) {
  static std::map<std::tuple<int, double, int>, Scene> cache;
  const auto key = std::make_tuple(n, outliers, static_cast<int>(model));
  auto it = cache.find(key);
  if (it == cache.end()) {
    SceneOptions o;
    o.n = n;
    o.noise_px = kNoisePx;
    o.outlier_fraction = outliers;
    o.model = model;
    o.seed = 1000 + static_cast<std::uint64_t>(n);
    it = cache.emplace(key, gimm_bench::make_scene(o)).first;
  }
  return it->second;
}

void set_accuracy(benchmark::State& state, const Scene& s,
                  const std::optional<Eigen::Matrix3d>& F) {
  state.counters["epi_px"] =
      F ? gimm_bench::mean_symmetric_epipolar_px(*F, s.true_a, s.true_b) : -1.0;
}

void BM_Gimm8pt(benchmark::State& state) {
  const Scene& s = scene(static_cast<int>(state.range(0)), 0.0);
  std::optional<Eigen::Matrix3d> F;
  for (auto _ : state) {
    F = gimm::fundamental_8pt<double>(s.obs_a, s.obs_b);
    benchmark::DoNotOptimize(F);
  }
  set_accuracy(state, s, F);
}
BENCHMARK(BM_Gimm8pt)->Arg(8)->Arg(64)->Arg(256)->Arg(1024)->Unit(benchmark::kMicrosecond);

/// RANSAC's minimal solver (LU on the 8 x 9 system), against BM_Gimm8pt/8 (the eigensolver).
void BM_Gimm8ptMinimal(benchmark::State& state) {
  const Scene& s = scene(8, 0.0);
  std::optional<Eigen::Matrix3d> F;
  for (auto _ : state) {
    F = gimm::fundamental_8pt_minimal<double>(s.obs_a, s.obs_b);
    benchmark::DoNotOptimize(F);
  }
  set_accuracy(state, s, F);
}
BENCHMARK(BM_Gimm8ptMinimal)->Unit(benchmark::kMicrosecond);

void BM_Gimm8ptWeighted(benchmark::State& state) {
  const Scene& s = scene(static_cast<int>(state.range(0)), 0.0);
  gimm::Rng rng(7);
  gimm::VectorX<double> w(s.obs_a.cols());
  for (Eigen::Index i = 0; i < w.size(); ++i) w(i) = rng.uniform(0.5, 1.0);
  std::optional<Eigen::Matrix3d> F;
  for (auto _ : state) {
    F = gimm::fundamental_8pt<double>(s.obs_a, s.obs_b, w);
    benchmark::DoNotOptimize(F);
  }
  set_accuracy(state, s, F);
}
BENCHMARK(BM_Gimm8ptWeighted)->Arg(8)->Arg(64)->Arg(256)->Arg(1024)->Unit(benchmark::kMicrosecond);

void BM_GimmAffine(benchmark::State& state) {
  const Scene& s =
      scene(static_cast<int>(state.range(0)), 0.0, gimm::ProjectionModel::orthographic);
  std::optional<Eigen::Matrix3d> F;
  for (auto _ : state) {
    F = gimm::fundamental_affine<double>(s.obs_a, s.obs_b);
    benchmark::DoNotOptimize(F);
  }
  set_accuracy(state, s, F);
}
BENCHMARK(BM_GimmAffine)->Arg(8)->Arg(64)->Arg(256)->Arg(1024)->Unit(benchmark::kMicrosecond);

void BM_GimmRansac(benchmark::State& state) {
  const Scene& s = scene(static_cast<int>(state.range(0)), kOutliers);
  gimm::RansacOptions options;
  options.threshold_px = kThresholdPx;
  gimm::RansacResult<double> result;
  for (auto _ : state) {
    result = gimm::estimate_fundamental_ransac<double>(s.obs_a, s.obs_b, options);
    benchmark::DoNotOptimize(result);
  }
  set_accuracy(state, s, result.F);
  state.counters["iterations"] = static_cast<double>(result.stats.iterations);
  state.counters["local_opt"] = static_cast<double>(result.stats.local_optimizations);
  state.counters["inliers"] = static_cast<double>(result.stats.num_inliers);
}
BENCHMARK(BM_GimmRansac)->Arg(64)->Arg(256)->Arg(1024)->Unit(benchmark::kMicrosecond);

#ifdef GIMM_HAVE_OPENCV
void BM_OpenCV8point(benchmark::State& state) {
  const Scene& s = scene(static_cast<int>(state.range(0)), 0.0);
  const auto a = gimm_bench::to_cv(s.obs_a), b = gimm_bench::to_cv(s.obs_b);
  std::optional<Eigen::Matrix3d> F;
  for (auto _ : state) {
    F = gimm_bench::opencv_fundamental(a, b, cv::FM_8POINT);
    benchmark::DoNotOptimize(F);
  }
  set_accuracy(state, s, F);
}
BENCHMARK(BM_OpenCV8point)->Arg(8)->Arg(64)->Arg(256)->Arg(1024)->Unit(benchmark::kMicrosecond);

template <int Method>
void BM_OpenCVRobust(benchmark::State& state) {
  const Scene& s = scene(static_cast<int>(state.range(0)), kOutliers);
  const auto a = gimm_bench::to_cv(s.obs_a), b = gimm_bench::to_cv(s.obs_b);
  const gimm::RansacOptions defaults;  // same confidence and iteration cap as gimm
  std::optional<Eigen::Matrix3d> F;
  int inliers = 0;
  for (auto _ : state) {
    cv::setRNGSeed(0);  // OpenCV's RANSAC draws from the global RNG
    F = gimm_bench::opencv_fundamental(a, b, Method, kThresholdPx, defaults.confidence,
                                       static_cast<int>(defaults.max_iterations), &inliers);
    benchmark::DoNotOptimize(F);
  }
  set_accuracy(state, s, F);
  state.counters["inliers"] = inliers;
}
/// FM_RANSAC: the classic 7-point RANSAC; USAC_ACCURATE: OpenCV's USAC framework (GC-RANSAC
/// local optimisation), shown for reference.
BENCHMARK_TEMPLATE(BM_OpenCVRobust, cv::FM_RANSAC)
    ->Arg(64)
    ->Arg(256)
    ->Arg(1024)
    ->Unit(benchmark::kMicrosecond);
BENCHMARK_TEMPLATE(BM_OpenCVRobust, cv::USAC_ACCURATE)
    ->Arg(64)
    ->Arg(256)
    ->Arg(1024)
    ->Unit(benchmark::kMicrosecond);
#endif

/// 10^6 points in the 120 mm cube around the isocentre.
const std::vector<Eigen::Vector3d>& million_points() {
  static const std::vector<Eigen::Vector3d> points = [] {
    gimm::Rng rng(3);
    std::vector<Eigen::Vector3d> p(1000000);
    for (auto& x : p) x = {rng.uniform(-60, 60), rng.uniform(-60, 60), rng.uniform(-60, 60)};
    return p;
  }();
  return points;
}

gimm::Camerad bench_camera(gimm::ProjectionModel model) {
  gimm::CArm arm;
  arm.primary_deg = 30;
  arm.secondary_deg = 20;
  arm.model = model;
  return arm.camera();
}

template <gimm::ProjectionModel Model>
void BM_Project1e6(benchmark::State& state) {
  const auto& points = million_points();
  const gimm::Camerad camera = bench_camera(Model);
  for (auto _ : state) {
    Eigen::Vector2d sum = Eigen::Vector2d::Zero();
    for (const auto& X : points) sum += camera.project(X).uv;
    benchmark::DoNotOptimize(sum);
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(points.size()));
}
BENCHMARK_TEMPLATE(BM_Project1e6, gimm::ProjectionModel::perspective)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_TEMPLATE(BM_Project1e6, gimm::ProjectionModel::orthographic)
    ->Unit(benchmark::kMillisecond);

/// Reference: the same projection as one (3x4) x (4 x 10^6) Eigen product and a division.
void BM_ProjectMatrix1e6(benchmark::State& state) {
  const auto& points = million_points();
  const gimm::Camerad camera = bench_camera(gimm::ProjectionModel::perspective);
  Eigen::Matrix<double, 4, Eigen::Dynamic> X(4, static_cast<Eigen::Index>(points.size()));
  for (std::size_t i = 0; i < points.size(); ++i)
    X.col(static_cast<Eigen::Index>(i)) = points[i].homogeneous();
  const Eigen::Matrix<double, 3, 4> P = camera.P();
  gimm::Points2<double> uv(2, X.cols());
  for (auto _ : state) {
    uv = (P * X).colwise().hnormalized();
    benchmark::DoNotOptimize(uv.data());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(points.size()));
}
BENCHMARK(BM_ProjectMatrix1e6)->Unit(benchmark::kMillisecond);

#ifdef GIMM_HAVE_OPENCV
void BM_OpenCVProjectPoints1e6(benchmark::State& state) {
  const auto& points = million_points();
  const gimm::Camerad camera = bench_camera(gimm::ProjectionModel::perspective);
  std::vector<cv::Point3d> X(points.size());
  for (std::size_t i = 0; i < points.size(); ++i)
    X[i] = {points[i].x(), points[i].y(), points[i].z()};
  cv::Mat R(3, 3, CV_64F), K(3, 3, CV_64F), rvec, tvec(3, 1, CV_64F);
  for (int r = 0; r < 3; ++r) {
    tvec.at<double>(r) = camera.t()(r);
    for (int c = 0; c < 3; ++c) {
      R.at<double>(r, c) = camera.R()(r, c);
      K.at<double>(r, c) = camera.K()(r, c);
    }
  }
  cv::Rodrigues(R, rvec);
  std::vector<cv::Point2d> uv;
  for (auto _ : state) {
    cv::projectPoints(X, rvec, tvec, K, cv::noArray(), uv);
    benchmark::DoNotOptimize(uv.data());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(points.size()));
}
BENCHMARK(BM_OpenCVProjectPoints1e6)->Unit(benchmark::kMillisecond);
#endif

}  // namespace

BENCHMARK_MAIN();
