// Exact radiological path: analytic chords, fast (Jacobs) vs slow (Siddon) path, edge cases.
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>

#include "gimm/core/rng.hpp"
#include "gimm/render/siddon.hpp"

using namespace gimm;

namespace {

VolumeGeometry grid(int nx, int ny, int nz, Eigen::Vector3d spacing = {1, 1, 1}) {
  VolumeGeometry g;
  g.dims = {nx, ny, nz};
  g.spacing = spacing;
  return g;
}

Ray<double> world_ray(Eigen::Vector3d origin, Eigen::Vector3d direction) {
  return {origin, direction.normalized()};
}

/// Analytic chord length (mm) of a world ray through the world-space box [lo, hi] (s >= 0).
double box_chord(const Ray<double>& r, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  double s0 = 0, s1 = 1e300;
  for (int a = 0; a < 3; ++a) {
    if (r.direction[a] == 0) {
      if (r.origin[a] < lo[a] || r.origin[a] > hi[a]) return 0;
      continue;
    }
    double t0 = (lo[a] - r.origin[a]) / r.direction[a], t1 = (hi[a] - r.origin[a]) / r.direction[a];
    if (t0 > t1) std::swap(t0, t1);
    s0 = std::max(s0, t0);
    s1 = std::min(s1, t1);
  }
  return std::max(0.0, s1 - s0);
}

/// siddon_integral from s_min to the exit (its s_max left at infinity).
template <class T>
double from(const Volume<T>& v, const IndexRay& r, double s_min) {
  return siddon_integral(v, r, s_min);
}

/// siddon_integral_pair with the ray under test in either slot (the other a long oblique ray).
template <class T>
double pair_first(const Volume<T>& v, const IndexRay& r, double s_min) {
  double a = 0, b = 0;
  siddon_integral_pair(v, r, IndexRay{{-5, -4, -3}, {0.5, 0.6, 0.7}}, a, b, s_min);
  return a;
}
template <class T>
double pair_second(const Volume<T>& v, const IndexRay& r, double s_min) {
  double a = 0, b = 0;
  siddon_integral_pair(v, IndexRay{{-5, -4, -3}, {0.5, 0.6, 0.7}}, r, a, b, s_min);
  return b;
}

using Integral = double (*)(const Volume<float>&, const IndexRay&, double);

/// Every exact path: Jacobs' incremental path (alone and paired) and the sorted reference.
Integral any_exact_path() {
  return GENERATE(Integral(&from<float>), Integral(&pair_first<float>),
                  Integral(&pair_second<float>), Integral(&siddon_integral_reference<float>));
}

}  // namespace

TEST_CASE("Siddon: chord through a uniform box equals the analytic length", "[render][siddon]") {
  const Integral integral = any_exact_path();
  // 20 x 30 x 10 voxels of 0.7 x 0.5 x 1.2 mm, value 1: the integral is the chord length.
  const Eigen::Vector3d spacing(0.7, 0.5, 1.2);
  VolumeGeometry g = grid(20, 30, 10, spacing);
  g.origin = Eigen::Vector3d(-3, 2, 5);
  Volume<float> ones(g, 1.0f);
  const Eigen::Vector3d lo = g.origin - 0.5 * spacing;
  const Eigen::Vector3d hi = lo + Eigen::Vector3d(20 * 0.7, 30 * 0.5, 10 * 1.2);
  Rng rng(7);
  int hits = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const Eigen::Vector3d centre = 0.5 * (lo + hi);
    const Eigen::Vector3d source =
        centre + Eigen::Vector3d(rng.normal(), rng.normal(), rng.normal()).normalized() * 60.0;
    const Eigen::Vector3d target(rng.uniform(lo.x() - 2, hi.x() + 2),
                                 rng.uniform(lo.y() - 2, hi.y() + 2),
                                 rng.uniform(lo.z() - 2, hi.z() + 2));
    const auto r = world_ray(source, target - source);
    const double expected = box_chord(r, lo, hi);
    const double got = integral(ones, to_index_ray(g, r), 0.0);
    hits += expected > 0;
    REQUIRE(got == Approx(expected).epsilon(1e-9).margin(1e-9));
  }
  CHECK(hits > 500);
}

TEST_CASE("Siddon: an inner block with faces on voxel planes (the voxel model)",
          "[render][siddon]") {
  const Integral integral = any_exact_path();
  VolumeGeometry g = grid(16, 16, 16);
  Volume<float> v(g, 0.0f);
  for (int k = 4; k < 12; ++k)
    for (int j = 3; j < 9; ++j)
      for (int i = 5; i < 13; ++i) v(i, j, k) = 2.5f;
  // World box of the block: voxel i spans [i - 0.5, i + 0.5].
  const Eigen::Vector3d lo(4.5, 2.5, 3.5), hi(12.5, 8.5, 11.5);
  Rng rng(11);
  for (int trial = 0; trial < 1000; ++trial) {
    const Eigen::Vector3d source(rng.uniform(-40, 60), rng.uniform(-40, 60), -30);
    const Eigen::Vector3d target(rng.uniform(3, 14), rng.uniform(1, 10), rng.uniform(2, 13));
    const auto r = world_ray(source, target - source);
    const double expected = 2.5 * box_chord(r, lo, hi);
    REQUIRE(integral(v, to_index_ray(g, r), 0.0) == Approx(expected).epsilon(1e-5).margin(1e-9));
  }
}

TEST_CASE("Siddon: fast path equals the sorted-crossings reference on random volumes",
          "[render][siddon]") {
  VolumeGeometry g = grid(13, 9, 17, {0.8, 1.1, 0.6});
  g.origin = Eigen::Vector3d(1, -2, 3);
  // Oblique direction cosines: both paths must honour them.
  g.direction = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  Volume<float> v(g);
  Rng rng(3);
  for (auto& x : v.storage()) x = static_cast<float>(rng.uniform());
  for (int trial = 0; trial < 3000; ++trial) {
    const Eigen::Vector3d source(rng.uniform(-30, 30), rng.uniform(-30, 30), rng.uniform(-30, 30));
    const Eigen::Vector3d target = v.index_to_world(
        Eigen::Vector3d(rng.uniform(-2, 14), rng.uniform(-2, 10), rng.uniform(-2, 18)));
    const IndexRay r = to_index_ray(g, world_ray(source, target - source));
    const double reference = siddon_integral_reference(v, r);
    REQUIRE(siddon_integral(v, r) == Approx(reference).epsilon(1e-10).margin(1e-12));
    REQUIRE(pair_second(v, r, 0.0) == Approx(reference).epsilon(1e-10).margin(1e-12));
  }
}

TEST_CASE("Siddon: edge cases", "[render][siddon]") {
  const Integral integral = any_exact_path();
  VolumeGeometry g = grid(8, 8, 8);
  Volume<float> v(g);
  Rng rng(5);
  for (auto& x : v.storage()) x = static_cast<float>(rng.uniform(0.5, 1.5));

  SECTION("a ray that misses returns 0") {
    const auto r = to_index_ray(g, world_ray({-50, 50, 3}, {1, 0, 0}));
    CHECK(integral(v, r, 0.0) == 0.0);
  }
  SECTION("a ray with a NaN or infinite coordinate misses (clip_to_box refuses it)") {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const double inf = std::numeric_limits<double>::infinity();
    for (const IndexRay& r :
         {IndexRay{{nan, 3.0, 3.0}, {1.0, 0.0, 0.0}}, IndexRay{{-4.0, 3.0, 3.0}, {1.0, nan, 0.0}},
          IndexRay{{-4.0, 3.0, 3.0}, {1.0, 0.0, inf}},
          IndexRay{{3.0, 3.0, -inf}, {0.0, 0.0, 1.0}}}) {
      double s0, s1;
      CHECK_FALSE(clip_to_box(r, glm::dvec3(0.0), glm::dvec3(8.0), 0.0, s0, s1));
      CHECK(integral(v, r, 0.0) == 0.0);
    }
  }
  SECTION("a ray pointing away from the volume returns 0 (integration starts at the source)") {
    const auto r = to_index_ray(g, world_ray({-20, 3.2, 3.3}, {-1, 0, 0}));
    CHECK(integral(v, r, 0.0) == 0.0);
  }
  SECTION("axis-parallel rays through voxel centres sum one row of voxels") {
    for (int axis = 0; axis < 3; ++axis) {
      Eigen::Vector3d origin(2, 5, 6), dir = Eigen::Vector3d::Zero();
      origin[axis] = -10;
      dir[axis] = 1;
      double expected = 0;
      for (int m = 0; m < 8; ++m) {
        int idx[3] = {2, 5, 6};
        idx[axis] = m;
        expected += v(idx[0], idx[1], idx[2]);
      }
      const auto r = to_index_ray(g, world_ray(origin, dir));
      CHECK(integral(v, r, 0.0) == Approx(expected).epsilon(1e-12));
    }
  }
  SECTION("a ray lying in a voxel face takes the voxels on the [i, i+1) side") {
    // Face x = 2.5 (between voxels 2 and 3), along y at z = 4: the voxels with i = 3.
    const auto r = to_index_ray(g, world_ray({2.5, -10, 4}, {0, 1, 0}));
    double expected = 0;
    for (int j = 0; j < 8; ++j) expected += v(3, j, 4);
    CHECK(integral(v, r, 0.0) == Approx(expected).epsilon(1e-12));
  }
  SECTION("a ray through voxel corners (the main diagonal) is exact") {
    Volume<float> ones(g, 1.0f);
    const auto r = to_index_ray(g, world_ray({-0.5 - 3, -0.5 - 3, -0.5 - 3}, {1, 1, 1}));
    CHECK(integral(ones, r, 0.0) == Approx(8 * std::sqrt(3.0)).epsilon(1e-12));
    // With values: the diagonal visits exactly the voxels (m, m, m).
    double expected = 0;
    for (int m = 0; m < 8; ++m) expected += std::sqrt(3.0) * v(m, m, m);
    CHECK(integral(v, r, 0.0) == Approx(expected).epsilon(1e-12));
  }
  SECTION("a ray starting inside the volume integrates from its origin") {
    Volume<float> ones(g, 1.0f);
    const auto r = to_index_ray(g, world_ray({3.1, 4.2, 2.0}, {0, 0, 1}));
    CHECK(integral(ones, r, 0.0) == Approx(7.5 - 2.0).epsilon(1e-12));
  }
}
