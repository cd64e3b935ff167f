// DRR time against error: both projectors on a volume of Gaussian blobs whose line integrals are
// known in closed form (sigma sqrt(2 pi) exp(-d^2 / 2 sigma^2) per blob), 256^3 -> 512^2.
// Counters: rel_error = mean |DRR - analytic| / analytic over pixels above 1% of the maximum.
// Chart: benchmarks/drr/plot_time_vs_error.sh.
#include <benchmark/benchmark.h>

#include <cmath>
#include <vector>

#include "gimm/core/rng.hpp"
#include "gimm/geometry/carm.hpp"
#include "gimm/render/drr.hpp"

namespace {

struct Blob {
  Eigen::Vector3d centre;
  double sigma;
  double amplitude;
};

struct Scene {
  gimm::Volume<float> volume;
  std::vector<Blob> blobs;
  gimm::Camerad camera;
  gimm::Image<float> analytic;
};

const Scene& scene() {
  static const Scene s = [] {
    gimm::Rng rng(2024);
    std::vector<Blob> blobs;
    for (int b = 0; b < 60; ++b)
      blobs.push_back({{rng.uniform(-50, 50), rng.uniform(-50, 50), rng.uniform(-50, 50)},
                       rng.uniform(0.6, 8.0),
                       rng.uniform(0.005, 0.03)});
    gimm::VolumeGeometry g;
    g.dims = {256, 256, 256};
    g.spacing = Eigen::Vector3d::Constant(0.75);
    g.origin = Eigen::Vector3d::Constant(-255 * 0.75 / 2);
    gimm::Volume<float> v(g, 0.0f);
    gimm::parallel_for(0, 256, [&](std::int64_t k) {
      for (int j = 0; j < 256; ++j)
        for (int i = 0; i < 256; ++i) {
          const Eigen::Vector3d p = v.index_to_world(Eigen::Vector3d(i, j, k));
          double sum = 0;
          for (const auto& blob : blobs) {
            const double r2 = (p - blob.centre).squaredNorm();
            if (r2 < 25 * blob.sigma * blob.sigma)
              sum += blob.amplitude * std::exp(-r2 / (2 * blob.sigma * blob.sigma));
          }
          v(i, j, static_cast<int>(k)) = static_cast<float>(sum);
        }
    });
    gimm::CArm carm;
    carm.primary_deg = 30;
    carm.secondary_deg = 20;
    const gimm::Camerad camera = carm.camera();
    gimm::Image<float> analytic(camera.rows(), camera.cols());
    for (int r = 0; r < camera.rows(); ++r)
      for (int c = 0; c < camera.cols(); ++c) {
        const auto ray = camera.ray(c, r);
        double sum = 0;
        for (const auto& blob : blobs) {
          const Eigen::Vector3d w = blob.centre - ray.origin;
          const double d2 = (w - w.dot(ray.direction) * ray.direction).squaredNorm();
          sum += blob.amplitude * blob.sigma * std::sqrt(2 * gimm::kPi) *
                 std::exp(-d2 / (2 * blob.sigma * blob.sigma));
        }
        analytic(r, c) = static_cast<float>(sum);
      }
    return Scene{std::move(v), blobs, camera, std::move(analytic)};
  }();
  return s;
}

double mean_relative_error(const gimm::Image<float>& drr, const gimm::Image<float>& truth) {
  float peak = 0;
  for (const float x : truth.storage()) peak = std::max(peak, x);
  double sum = 0;
  std::int64_t n = 0;
  for (std::size_t p = 0; p < drr.size(); ++p) {
    const double t = truth.data()[p];
    if (t < 0.01 * peak) continue;
    sum += std::abs(drr.data()[p] - t) / t;
    ++n;
  }
  return sum / static_cast<double>(n);
}

void run(benchmark::State& state, const gimm::DrrOptions& options) {
  const Scene& s = scene();
  gimm::Image<float> drr;
  for (auto _ : state) {
    drr = gimm::render_line_integrals(s.volume, s.camera, options);
    benchmark::DoNotOptimize(drr.data());
  }
  state.counters["rel_error"] = mean_relative_error(drr, s.analytic);
  state.counters["step_voxels"] = options.step_mm / 0.75;
}

void BM_Accuracy_Siddon(benchmark::State& state) {
  gimm::DrrOptions options;
  options.projector = gimm::Projector::siddon;
  run(state, options);
}
BENCHMARK(BM_Accuracy_Siddon)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_Accuracy_Trilinear(benchmark::State& state) {
  gimm::DrrOptions options;
  options.projector = gimm::Projector::trilinear;
  options.step_mm = 0.75 * static_cast<double>(state.range(0)) / 100.0;
  run(state, options);
}
BENCHMARK(BM_Accuracy_Trilinear)
    ->Arg(400)
    ->Arg(200)
    ->Arg(100)
    ->Arg(50)
    ->Arg(25)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
