// Trilinear ray marching: fast vs slow path, convergence as the step shrinks.
#include <array>
#include <catch2/catch.hpp>
#include <cmath>
#include <vector>

#include "gimm/core/rng.hpp"
#include "gimm/render/trilinear.hpp"

#include <glm/geometric.hpp>

using namespace gimm;

namespace {
Volume<float> gaussian_blob(int n, double spacing) {
  VolumeGeometry g;
  g.dims = {n, n, n};
  g.spacing = Eigen::Vector3d::Constant(spacing);
  g.origin = Eigen::Vector3d::Constant(-(n - 1) * spacing / 2);
  Volume<float> v(g);
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const Eigen::Vector3d p = v.index_to_world(Eigen::Vector3d(i, j, k));
        v(i, j, k) = static_cast<float>(std::exp(-p.squaredNorm() / (2 * 6.0 * 6.0)));
      }
  return v;
}
}  // namespace

TEST_CASE("Trilinear: fast path equals Volume::sample_index marching", "[render][trilinear]") {
  VolumeGeometry g;
  g.dims = {11, 14, 9};
  g.spacing = {0.9, 0.7, 1.3};
  g.direction = Eigen::AngleAxisd(0.4, Eigen::Vector3d(0, 1, 1).normalized()).toRotationMatrix();
  Volume<float> v(g);
  Rng rng(9);
  for (auto& x : v.storage()) x = static_cast<float>(rng.uniform());
  for (int trial = 0; trial < 500; ++trial) {
    const Eigen::Vector3d s(rng.uniform(-30, 30), rng.uniform(-30, 30), rng.uniform(-30, 30));
    const Eigen::Vector3d t = v.index_to_world(
        Eigen::Vector3d(rng.uniform(-1, 11), rng.uniform(-1, 14), rng.uniform(-1, 9)));
    const IndexRay r = to_index_ray(g, {s, (t - s).normalized()});
    const double step = rng.uniform(0.1, 1.5);
    REQUIRE(trilinear_integral(v, r, step) ==
            Approx(trilinear_integral_reference(v, r, step)).epsilon(1e-10).margin(1e-12));
  }
}

TEST_CASE("Trilinear: converges as the step shrinks", "[render][trilinear]") {
  const Volume<float> v = gaussian_blob(48, 1.0);
  Rng rng(21);
  std::vector<IndexRay> rays;
  std::vector<double> fine;
  for (int m = 0; m < 40; ++m) {
    // Oblique rays from random directions, so steps do not align with the voxel planes.
    const Eigen::Vector3d dir =
        Eigen::Vector3d(rng.normal(), rng.normal(), rng.normal()).normalized();
    const Eigen::Vector3d t(rng.uniform(-8, 8), rng.uniform(-8, 8), rng.uniform(-8, 8));
    const Eigen::Vector3d s = t - 70 * dir;
    rays.push_back(to_index_ray(v.geometry(), {s, (t - s).normalized()}));
    fine.push_back(trilinear_integral(v, rays.back(), 0.001));
  }
  // Mean error over many rays: single rays can be lucky (midpoints aligned with the kinks of
  // the interpolant on voxel planes); the mean falls at about second order.
  std::vector<double> mean_error;
  for (double step : {2.0, 1.0, 0.5, 0.25, 0.125}) {
    double sum = 0;
    for (std::size_t m = 0; m < rays.size(); ++m)
      sum += std::abs(trilinear_integral(v, rays[m], step) - fine[m]) / fine[m];
    mean_error.push_back(sum / rays.size());
  }
  for (std::size_t e = 1; e < mean_error.size(); ++e) CHECK(mean_error[e] < mean_error[e - 1]);
  CHECK(mean_error.back() < mean_error.front() / 50);
  CHECK(mean_error.back() < 1e-5);
  CHECK_THROWS_WITH(trilinear_integral(v, rays[0], 0.0), Catch::Contains("step must be > 0"));
}

TEST_CASE("Trilinear: the line integral of a smooth blob matches the analytic one",
          "[render][trilinear]") {
  const Volume<float> v = gaussian_blob(48, 1.0);
  // Along x at distance d from the centre: sigma sqrt(2 pi) exp(-d^2 / (2 sigma^2)).
  const double d2 = 1.3 * 1.3 + 0.7 * 0.7;
  const IndexRay r = to_index_ray(v.geometry(), {{-60, 1.3, -0.7}, {1, 0, 0}});
  const double analytic = 6.0 * std::sqrt(2 * 3.14159265358979) * std::exp(-d2 / 72.0);
  CHECK(trilinear_integral(v, r, 0.05) == Approx(analytic).epsilon(0.01));
}

TEST_CASE("Trilinear: volumes with a one-voxel side and near-axis rays stay in bounds",
          "[render][trilinear]") {
  // A side of one voxel has no interior; rays with direction components of round-off size
  // (cos 90 deg ~ 6e-17) must not take the unchecked path (it would read past the data).
  for (const auto& dims : {std::array<int, 3>{4, 4, 1}, {1, 5, 3}, {6, 1, 1}, {2, 2, 2}}) {
    VolumeGeometry g;
    g.dims = {dims[0], dims[1], dims[2]};
    Volume<float> v(g);
    Rng rng(3);
    for (auto& x : v.storage()) x = static_cast<float>(rng.uniform());
    for (double tiny : {0.0, 1e-12, -1e-12, 6e-17}) {
      IndexRay r;
      r.origin = glm::dvec3(0.5, -5.0, 0.0);
      r.direction = glm::dvec3(tiny, 1.0, tiny);
      for (double step : {0.3, 1.0}) {
        CHECK(trilinear_integral(v, r, step) ==
              Approx(trilinear_integral_reference(v, r, step)).epsilon(1e-10).margin(1e-12));
      }
    }
  }
}

TEST_CASE("Trilinear: the SIMD interior sampler equals the scalar one", "[render][trilinear]") {
  VolumeGeometry g;
  g.dims = {23, 19, 17};
  Volume<float> v(g);
  Rng rng(4);
  for (auto& x : v.storage()) x = static_cast<float>(rng.uniform(-1, 2));
  for (int trial = 0; trial < 2000; ++trial) {
    // A ray from one interior point to another (all samples interior), sampled from k0 on.
    const glm::dvec3 a(rng.uniform(0, 22), rng.uniform(0, 18), rng.uniform(0, 16));
    const glm::dvec3 b(rng.uniform(0, 22), rng.uniform(0, 18), rng.uniform(0, 16));
    const double length = glm::length(b - a);
    if (length < 1e-3) continue;
    const IndexRay r{a, (b - a) / length};
    const double step = length / static_cast<double>(rng.uniform_int(1, 40));
    const auto n = static_cast<std::int64_t>(std::floor(length / step)) - 1;
    std::vector<double> fast(std::max<std::int64_t>(n, 0)), slow(fast.size());
    detail::interior_samples(v, r, 0.0, step, 0, n, fast.data());
    detail::interior_samples_scalar(v, r, 0.0, step, 0, n, slow.data());
    for (std::size_t q = 0; q < fast.size(); ++q)
      REQUIRE(fast[q] == Approx(slow[q]).epsilon(1e-12).margin(1e-12));
  }
}
