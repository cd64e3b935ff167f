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

namespace {
// Sparse blobs in air: most 8^3 blocks are empty, some are not, and blob edges straddle block
// faces. Values are strictly zero away from the blobs.
Volume<float> blobs_in_air(const VolumeGeometry& g, std::uint64_t seed) {
  Volume<float> v(g, 0.0f);
  Rng rng(seed);
  for (int b = 0; b < 6; ++b) {
    const Eigen::Vector3d c(rng.uniform(0, g.dims[0]), rng.uniform(0, g.dims[1]),
                            rng.uniform(0, g.dims[2]));
    const double r = rng.uniform(3.0, 12.0);
    for (int k = 0; k < g.dims[2]; ++k)
      for (int j = 0; j < g.dims[1]; ++j)
        for (int i = 0; i < g.dims[0]; ++i)
          if ((Eigen::Vector3d(i, j, k) - c).norm() < r)
            v(i, j, k) += static_cast<float>(rng.uniform(0.5, 1.5));
  }
  return v;
}
}  // namespace

TEST_CASE("Empty blocks: a block is empty exactly when its cells' voxels are all zero",
          "[render][trilinear][empty]") {
  constexpr int B = EmptyBlocks::kSize;
  VolumeGeometry g;
  g.dims = {2 * B + 4, 2 * B + 1, B + 3};  // 3 x 2 x 2 blocks of cells, partial on every axis
  Volume<float> v(g, 0.0f);
  v(B, 0, 0) = 1.0f;  // voxel B is the +1 neighbour of cell B - 1 (block 0) and in block 1
  const EmptyBlocks empty(v);
  CHECK_FALSE(empty.empty_at_cell(0, 0, 0));
  CHECK_FALSE(empty.empty_at_cell(B - 1, 0, 0));
  CHECK_FALSE(empty.empty_at_cell(B, 0, 0));
  CHECK(empty.empty_at_cell(2 * B, 0, 0));
  CHECK(empty.empty_at_cell(0, B, 0));
  CHECK(empty.empty_at_cell(0, 0, B));
  CHECK(empty.empty_fraction() == Approx(10.0 / 12.0));
  v(B, 0, 0) = 0.0f;
  v(2 * B + 3, 2 * B, B + 2) = -2.0f;  // the last voxel; negative values are not empty either
  const EmptyBlocks empty2(v);
  CHECK(empty2.empty_at_cell(0, 0, 0));
  CHECK_FALSE(empty2.empty_at_cell(2 * B + 2, 2 * B - 1, B + 1));
  CHECK(empty2.empty_fraction() == Approx(11.0 / 12.0));
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
    for (std::size_t q = 0; q < fast.size(); ++q) REQUIRE(fast[q] == Approx(slow[q]).margin(1e-12));
  }
}

TEST_CASE("Trilinear: skipping empty blocks is bit-identical to the full walk",
          "[render][trilinear][empty]") {
  VolumeGeometry g;
  g.dims = {70, 53, 41};
  g.spacing = {0.8, 0.6, 1.1};
  g.direction = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 0).normalized()).toRotationMatrix();
  const Volume<float> v = blobs_in_air(g, 5);
  const EmptyBlocks empty(v);
  REQUIRE(empty.empty_fraction() > 0.3);
  REQUIRE(empty.empty_fraction() < 0.9);
  Rng rng(17);
  int non_zero = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    IndexRay r;
    if (trial % 3 == 0) {
      // Axis-parallel rays on block faces and cell corners (integer and half-block origins).
      const int axis = trial % 9 / 3;
      r.origin = glm::dvec3(8.0 * rng.uniform_int(0, 8), 8.0 * rng.uniform_int(0, 6),
                            rng.uniform_int(0, 40));
      r.origin[axis] = -3.0;
      r.direction = glm::dvec3(0.0);
      r.direction[axis] = 1.0 / g.spacing[axis];
      if (trial % 2) r.origin[(axis + 1) % 3] += 1e-13;  // a hair off the face
    } else {
      const Eigen::Vector3d s(rng.uniform(-40, 40), rng.uniform(-40, 40), rng.uniform(-40, 40));
      const Eigen::Vector3d t = v.index_to_world(
          Eigen::Vector3d(rng.uniform(0, 70), rng.uniform(0, 53), rng.uniform(0, 41)));
      r = to_index_ray(g, {s, (t - s).normalized()});
    }
    const double step = rng.uniform(0.05, 2.0);
    const double full = trilinear_integral(v, r, step);
    const double skipped = trilinear_integral(v, r, step, 0.0, &empty);
    // Equal up to rounding: a sample may fall in the vectorised body of one run and in the
    // scalar tail of another, where the compiler may contract multiply-adds differently
    // (measured: 2e-16 relative at worst).
    REQUIRE(skipped == Approx(full).epsilon(1e-13).margin(1e-300));
    REQUIRE(skipped ==
            Approx(trilinear_integral_reference(v, r, step)).epsilon(1e-10).margin(1e-12));
    non_zero += full != 0.0;
  }
  CHECK(non_zero > 500);
}
