// DRR projectors: exact Siddon/Jacobs and trilinear marching, 256^3 -> 512^2 (SID 1000,
// SOD 750), whole detector on all threads, plus ns per voxel crossing per core; and the same on
// the ImageCAS-size phantom (512 x 512 x 256 at 0.4 x 0.4 x 0.5 mm, angiography recipe).
#include <benchmark/benchmark.h>

#include <cmath>
#include <vector>

#include "gimm/anatomy/attenuation.hpp"
#include "gimm/anatomy/phantom.hpp"
#include "gimm/core/parallel.hpp"
#include "gimm/geometry/carm.hpp"
#include "gimm/render/drr.hpp"
#include "gimm/render/view_renderer.hpp"

namespace {

/// A 256^3 attenuation volume (0.75 mm voxels, 192 mm cube at the isocentre): a water
/// ellipsoid with a denser core, so rays do real work everywhere in the field of view.
const gimm::Volume<float>& test_volume() {
  static const gimm::Volume<float> volume = [] {
    gimm::VolumeGeometry g;
    g.dims = {256, 256, 256};
    g.spacing = Eigen::Vector3d::Constant(0.75);
    g.origin = Eigen::Vector3d::Constant(-255 * 0.75 / 2);
    gimm::Volume<float> v(g, 0.0f);
    for (int k = 0; k < 256; ++k)
      for (int j = 0; j < 256; ++j)
        for (int i = 0; i < 256; ++i) {
          const Eigen::Vector3d p = v.index_to_world(Eigen::Vector3d(i, j, k));
          const double r = (p.cwiseQuotient(Eigen::Vector3d(90, 70, 95))).squaredNorm();
          if (r < 1) v(i, j, k) = static_cast<float>(r < 0.2 ? 0.04 : 0.02);
        }
    return v;
  }();
  return volume;
}

gimm::Camerad test_camera(double primary) {
  gimm::CArm carm;
  carm.primary_deg = primary;
  carm.secondary_deg = 20;
  return carm.camera();
}

/// Voxel crossings (steps of the incremental traversal) over the whole detector.
std::int64_t count_crossings(const gimm::Volume<float>& v, const gimm::Camerad& camera) {
  const gimm::RayGenerator rays(camera);
  std::int64_t total = 0;
  for (int row = 0; row < camera.rows(); ++row)
    for (int col = 0; col < camera.cols(); ++col) {
      gimm::IndexRay r = gimm::to_index_ray(v.geometry(), rays(col, row));
      r.origin += 0.5;
      double s0, s1;
      if (!gimm::clip_to_box(r, glm::dvec3(0.0), glm::dvec3(v.nx(), v.ny(), v.nz()), 0.0, s0, s1))
        continue;
      std::int64_t n = 1;
      for (int a = 0; a < 3; ++a)
        n += std::abs(static_cast<std::int64_t>(std::floor(r.origin[a] + s1 * r.direction[a])) -
                      static_cast<std::int64_t>(std::floor(r.origin[a] + s0 * r.direction[a])));
      total += n;
    }
  return total;
}

/// Counters shared by the Siddon and ImageCAS cases: voxel crossings of the exact traversal over
/// the whole detector, threads, and ns per crossing per core (wall time x threads / crossings).
void set_crossing_counters(benchmark::State& state, const gimm::Volume<float>& v,
                           const gimm::Camerad& camera) {
  const double crossings = static_cast<double>(count_crossings(v, camera));
  state.counters["crossings"] = crossings;
  state.counters["threads"] = gimm::max_threads();
  state.counters["ns_per_crossing_core"] = benchmark::Counter(
      crossings / (1e9 * gimm::max_threads()),
      benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

void BM_Siddon_256cube_512det(benchmark::State& state) {
  const auto& v = test_volume();
  const auto camera = test_camera(30);
  gimm::DrrOptions options;
  options.projector = gimm::Projector::siddon;
  for (auto _ : state) benchmark::DoNotOptimize(gimm::render_line_integrals(v, camera, options));
  set_crossing_counters(state, v, camera);
}
BENCHMARK(BM_Siddon_256cube_512det)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_Trilinear_256cube_512det(benchmark::State& state) {
  const auto& v = test_volume();
  const auto camera = test_camera(30);
  gimm::DrrOptions options;
  options.projector = gimm::Projector::trilinear;
  options.step_mm = 0.75 * static_cast<double>(state.range(0)) / 100.0;
  options.skip_empty_space = state.range(1) != 0;
  for (auto _ : state) benchmark::DoNotOptimize(gimm::render_line_integrals(v, camera, options));
  state.counters["step_mm"] = options.step_mm;
  state.counters["skip_empty"] = static_cast<double>(options.skip_empty_space);
}
// Args: step in % of the voxel, empty-space skipping on (1) or off (0).
BENCHMARK(BM_Trilinear_256cube_512det)
    ->Args({100, 1})
    ->Args({100, 0})
    ->Args({50, 1})
    ->Args({200, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

/// The ImageCAS-size phantom (seed 1, 512 x 512 x 256 at 0.4 x 0.4 x 0.5 mm, default noise) as
/// attenuation (mm^-1): angiography recipe with the whole coronary label injected. Built once.
const gimm::Phantom& imagecas_phantom() {
  static const gimm::Phantom phantom = [] {
    gimm::PhantomOptions options;
    options.seed = 1;
    options.size = gimm::PhantomSize::imagecas;
    return gimm::make_phantom(options);
  }();
  return phantom;
}

const gimm::Volume<float>& phantom_volume() {
  static const gimm::Volume<float> volume = [] {
    const gimm::Phantom& p = imagecas_phantom();
    return gimm::make_attenuation(gimm::volume_cast<float>(p.hu), &p.label, gimm::ContrastRecipe{},
                                  "phantom");
  }();
  return volume;
}

/// LAO 30 / cranial 20 (test_camera(30)), isocentre at the world origin = the phantom grid's
/// centre.
void BM_Siddon_ImageCAS_512det(benchmark::State& state) {
  const auto& v = phantom_volume();
  const auto camera = test_camera(30);
  gimm::DrrOptions options;
  options.projector = gimm::Projector::siddon;
  for (auto _ : state) benchmark::DoNotOptimize(gimm::render_line_integrals(v, camera, options));
  set_crossing_counters(state, v, camera);
}
BENCHMARK(BM_Siddon_ImageCAS_512det)->Unit(benchmark::kMillisecond)->UseRealTime();

/// Trilinear at the smallest spacing (0.4 mm, one voxel in x and y; the default step).
void BM_Trilinear_ImageCAS_512det(benchmark::State& state) {
  const auto& v = phantom_volume();
  const auto camera = test_camera(30);
  gimm::DrrOptions options;
  options.projector = gimm::Projector::trilinear;
  options.step_mm = 0.4 * static_cast<double>(state.range(0)) / 100.0;
  for (auto _ : state) benchmark::DoNotOptimize(gimm::render_line_integrals(v, camera, options));
  state.counters["step_mm"] = options.step_mm;
  // Same counter as Siddon (voxel crossings of the exact traversal), for comparison.
  set_crossing_counters(state, v, camera);
}
BENCHMARK(BM_Trilinear_ImageCAS_512det)
    ->Arg(100)
    ->Arg(200)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

/// What gimm.Renderer(hu, label).render(camera) does from Python, in C++: the prepared view
/// renderer (angiography recipe, 80 mm pads, voxel vessels) on the ImageCAS-size phantom, one
/// view with its vessel mask and the Beer-Lambert intensity. benchmarks/python/drr_overhead.py
/// times the same from Python and compares.
void BM_ViewRenderer_ImageCAS_512det(benchmark::State& state) {
  static const gimm::ViewRenderer renderer(gimm::volume_cast<float>(imagecas_phantom().hu),
                                           &imagecas_phantom().label, gimm::RendererOptions{},
                                           "phantom");
  const auto camera = test_camera(30);
  for (auto _ : state) {
    gimm::RenderedView view = renderer.render(camera);
    benchmark::DoNotOptimize(view.intensity());
  }
  state.counters["threads"] = gimm::max_threads();
}
BENCHMARK(BM_ViewRenderer_ImageCAS_512det)->Unit(benchmark::kMillisecond)->UseRealTime();

/// Single-thread kernels side by side on the same rays: Jacobs' traversal one ray at a time
/// (here) and two interleaved (BM_SiddonPairKernel_1thread).
void BM_SiddonKernel_1thread(benchmark::State& state) {
  const auto& v = test_volume();
  const auto camera = test_camera(30);
  const gimm::RayGenerator rays(camera);
  std::vector<gimm::IndexRay> index_rays;
  for (int row = 0; row < camera.rows(); row += 2)
    for (int col = 0; col < camera.cols(); col += 2)
      index_rays.push_back(gimm::to_index_ray(v.geometry(), rays(col, row)));
  for (auto _ : state) {
    double sum = 0;
    for (const auto& r : index_rays) sum += gimm::siddon_integral(v, r);
    benchmark::DoNotOptimize(sum);
  }
  state.counters["rays"] = static_cast<double>(index_rays.size());
}
BENCHMARK(BM_SiddonKernel_1thread)->Unit(benchmark::kMillisecond);

void BM_SiddonPairKernel_1thread(benchmark::State& state) {
  const auto& v = test_volume();
  const auto camera = test_camera(30);
  const gimm::RayGenerator rays(camera);
  std::vector<gimm::IndexRay> index_rays;
  for (int row = 0; row < camera.rows(); row += 2)
    for (int col = 0; col < camera.cols(); col += 2)
      index_rays.push_back(gimm::to_index_ray(v.geometry(), rays(col, row)));
  for (auto _ : state) {
    double sum = 0, a = 0, b = 0;
    for (std::size_t m = 0; m + 1 < index_rays.size(); m += 2) {
      gimm::siddon_integral_pair(v, index_rays[m], index_rays[m + 1], a, b);
      sum += a + b;
    }
    benchmark::DoNotOptimize(sum);
  }
}
BENCHMARK(BM_SiddonPairKernel_1thread)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
