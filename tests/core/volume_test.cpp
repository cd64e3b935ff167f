// Volume<T>: (i, j, k) indexing with i fastest, voxel centre = origin + D diag(spacing) ijk,
// world <-> index round trips with an oblique direction, trilinear sampling.
#include <Eigen/Geometry>
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <numeric>
#include <vector>

#include "gimm/core/rng.hpp"
#include "gimm/core/volume.hpp"

using namespace gimm;

namespace {

/// An anisotropic, off-origin grid whose axes are rotated and one of them flipped (det -1).
VolumeGeometry oblique_geometry() {
  VolumeGeometry g;
  g.dims = {5, 4, 3};
  g.spacing = {0.4, 0.7, 1.5};
  g.origin = {-12.5, 30.25, 101.0};
  Eigen::Matrix3d D =
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, -2, 3).normalized()).toRotationMatrix();
  D.col(1) *= -1;  // a left-handed grid, as NIfTI allows
  g.direction = D;
  return g;
}

/// Voxel value that is an affine function of the index, so trilinear interpolation is exact.
double affine_value(int i, int j, int k) {
  return 1.5 + 2.0 * i - 3.0 * j + 0.5 * k;
}

}  // namespace

TEST_CASE("Volume memory order: i fastest, then j, then k", "[core][volume]") {
  VolumeGeometry g;
  g.dims = {4, 3, 2};
  Volume<int> v(g);
  REQUIRE(v.size() == 24);
  REQUIRE(v.nx() == 4);
  REQUIRE(v.ny() == 3);
  REQUIRE(v.nz() == 2);
  for (int k = 0; k < 2; ++k)
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 4; ++i) v(i, j, k) = 100 * k + 10 * j + i;
  for (int k = 0; k < 2; ++k)
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 4; ++i) {
        CHECK(v.linear_index(i, j, k) == static_cast<std::size_t>(i + 4 * (j + 3 * k)));
        CHECK(v.data()[i + 4 * (j + 3 * k)] == 100 * k + 10 * j + i);
      }
  CHECK(v.data()[1] == 1);     // (1, 0, 0)
  CHECK(v.data()[4] == 10);    // (0, 1, 0)
  CHECK(v.data()[12] == 100);  // (0, 0, 1)
  CHECK(v.contains(3, 2, 1));
  CHECK_FALSE(v.contains(4, 0, 0));
  CHECK_FALSE(v.contains(0, 3, 0));
  CHECK_FALSE(v.contains(0, 0, 2));
  CHECK_FALSE(v.contains(-1, 0, 0));
}

TEST_CASE("Volume voxel centres: origin + direction diag(spacing) ijk", "[core][volume]") {
  const VolumeGeometry g = oblique_geometry();
  const Volume<float> v(g);
  // origin is the centre of voxel (0, 0, 0).
  CHECK((v.index_to_world(Eigen::Vector3d::Zero()) - g.origin).norm() < 1e-12);
  // One step along each index axis moves spacing[a] mm along direction column a.
  for (int a = 0; a < 3; ++a) {
    Eigen::Vector3d e = Eigen::Vector3d::Zero();
    e[a] = 1;
    const Eigen::Vector3d step = v.index_to_world(e) - g.origin;
    CHECK(step.norm() == Approx(g.spacing[a]).epsilon(1e-12));
    CHECK((step - g.spacing[a] * g.direction.col(a)).norm() < 1e-12);
  }
  const Eigen::Vector3d ijk(2, 3, 1);
  const Eigen::Vector3d expected = g.origin + 2 * 0.4 * g.direction.col(0) +
                                   3 * 0.7 * g.direction.col(1) + 1 * 1.5 * g.direction.col(2);
  CHECK((v.index_to_world(ijk) - expected).norm() < 1e-12);
}

TEST_CASE("Volume world <-> index round trip with an oblique direction", "[core][volume]") {
  const VolumeGeometry g = oblique_geometry();
  Rng rng(11);
  for (int n = 0; n < 200; ++n) {
    const Eigen::Vector3d ijk(rng.uniform(-3, 8), rng.uniform(-3, 7), rng.uniform(-3, 6));
    const Eigen::Vector3d world = g.index_to_world(ijk);
    CHECK((g.world_to_index(world) - ijk).norm() < 1e-10);
    const Eigen::Vector3d w(rng.uniform(-50, 50), rng.uniform(-50, 50), rng.uniform(50, 150));
    CHECK((g.index_to_world(g.world_to_index(w)) - w).norm() < 1e-10);
  }
  // world_to_index is the inverse of the index->world matrix, not its transpose.
  const Eigen::Matrix3d A = g.index_to_world_matrix();
  const Eigen::Vector3d w(3, -4, 120);
  CHECK((g.world_to_index(w) - A.inverse() * (w - g.origin)).norm() < 1e-10);
}

TEST_CASE("Volume contains_index covers [-0.5, n - 0.5] on each axis", "[core][volume]") {
  const VolumeGeometry g = oblique_geometry();  // dims 5, 4, 3
  CHECK(g.contains_index({-0.5, -0.5, -0.5}));
  CHECK(g.contains_index({4.5, 3.5, 2.5}));
  CHECK_FALSE(g.contains_index({4.5001, 0, 0}));
  CHECK_FALSE(g.contains_index({0, -0.5001, 0}));
  CHECK_FALSE(g.contains_index({0, 0, 2.5001}));
  CHECK_FALSE(g.contains_index({std::nan(""), 0, 0}));
  CHECK(g.voxel_count() == 60);
}

TEST_CASE("Volume trilinear sampling", "[core][volume]") {
  const VolumeGeometry g = oblique_geometry();
  Volume<float> v(g);
  for (int k = 0; k < v.nz(); ++k)
    for (int j = 0; j < v.ny(); ++j)
      for (int i = 0; i < v.nx(); ++i) v(i, j, k) = static_cast<float>(affine_value(i, j, k));

  SECTION("at voxel centres it returns the voxel value, by index and by world position") {
    for (int k = 0; k < v.nz(); ++k)
      for (int j = 0; j < v.ny(); ++j)
        for (int i = 0; i < v.nx(); ++i) {
          const Eigen::Vector3d ijk(i, j, k);
          CHECK(v.sample_index(ijk) == Approx(v(i, j, k)).margin(1e-12));
          CHECK(v.sample_world(v.index_to_world(ijk)) == Approx(v(i, j, k)).margin(1e-9));
        }
  }
  SECTION("at a midpoint it returns the average of the neighbours") {
    // Edge midpoints (two voxels), face centres (four), cell centres (eight).
    CHECK(v.sample_index({1.5, 2, 1}) == Approx((v(1, 2, 1) + v(2, 2, 1)) / 2));
    CHECK(v.sample_index({3, 0.5, 0}) == Approx((v(3, 0, 0) + v(3, 1, 0)) / 2));
    CHECK(v.sample_index({0, 1, 1.5}) == Approx((v(0, 1, 1) + v(0, 1, 2)) / 2));
    CHECK(v.sample_index({2.5, 1.5, 1}) ==
          Approx((v(2, 1, 1) + v(3, 1, 1) + v(2, 2, 1) + v(3, 2, 1)) / 4));
    double sum = 0;
    for (int c = 0; c < 8; ++c) sum += v(1 + (c & 1), 2 + ((c >> 1) & 1), 0 + ((c >> 2) & 1));
    CHECK(v.sample_index({1.5, 2.5, 0.5}) == Approx(sum / 8));
    // A non-affine field makes the average distinguishable from any one corner.
    Volume<double> w(g, 0.0);
    w(1, 1, 1) = 8.0;
    CHECK(w.sample_index({1.5, 1.5, 1.5}) == Approx(1.0));
    CHECK(w.sample_index({1.5, 1, 1}) == Approx(4.0));
    CHECK(w.sample_index({1.25, 1, 1}) == Approx(6.0));
    CHECK(w.sample_world(w.index_to_world({1.5, 1, 1})) == Approx(4.0));
  }
  SECTION("anywhere inside it reproduces an affine field exactly") {
    Rng rng(5);
    for (int n = 0; n < 100; ++n) {
      const Eigen::Vector3d ijk(rng.uniform(0, 4), rng.uniform(0, 3), rng.uniform(0, 2));
      CHECK(v.sample_index(ijk) ==
            Approx(1.5 + 2.0 * ijk[0] - 3.0 * ijk[1] + 0.5 * ijk[2]).margin(1e-9));
    }
  }
  SECTION("outside voxels count as `outside`, falling off across the border half-voxel") {
    Volume<float> ones(g, 1.0f);
    CHECK(ones.sample_index({-0.5, 1, 1}) == Approx(0.5));
    CHECK(ones.sample_index({4.5, 1, 1}) == Approx(0.5));
    CHECK(ones.sample_index({-0.5, -0.5, 1}) == Approx(0.25));
    CHECK(ones.sample_index({-0.5, 1, 1}, 3.0) == Approx(2.0));
    CHECK(ones.sample_index({-2, 1, 1}) == 0.0);
    CHECK(ones.sample_index({-2, 1, 1}, 7.0) == Approx(7.0));
    CHECK(ones.sample_index({4, 3, 2}) == Approx(1.0));  // last voxel centre, no outside weight
  }
}

TEST_CASE("Volume geometry validation names the bad field", "[core][volume]") {
  VolumeGeometry g = oblique_geometry();
  REQUIRE_NOTHROW(Volume<float>(g));
  VolumeGeometry bad = g;
  bad.dims[1] = 0;
  CHECK_THROWS_WITH(Volume<float>(bad),
                    Catch::Matchers::Contains("dimension 1") && Catch::Matchers::Contains("got 0"));
  bad = g;
  bad.spacing[2] = -1.0;
  CHECK_THROWS_WITH(Volume<float>(bad),
                    Catch::Matchers::Contains("spacing 2") && Catch::Matchers::Contains("got -1"));
  bad = g;
  bad.spacing[0] = std::nan("");
  CHECK_THROWS_AS(Volume<float>(bad), Error);
  bad = g;
  bad.origin[0] = std::numeric_limits<double>::infinity();
  CHECK_THROWS_AS(Volume<float>(bad), Error);
  bad = g;
  bad.direction(0, 0) += 0.1;
  CHECK_THROWS_WITH(Volume<float>(bad), Catch::Matchers::Contains("orthonormal"));
  bad = g;
  bad.direction *= 2;
  CHECK_THROWS_AS(Volume<float>(bad), Error);
}

TEST_CASE("grid_difference names the first property two grids disagree on", "[core][volume]") {
  VolumeGeometry a;
  a.dims = {4, 5, 6};
  a.spacing = {0.4, 0.4, 0.5};
  a.origin = {10, -20, 30};
  CHECK(grid_difference(a, a).empty());
  VolumeGeometry b = a;
  b.spacing[2] += 0.5e-4;  // within tolerance
  b.origin[0] += 0.5e-3;
  CHECK(grid_difference(a, b).empty());
  b = a;
  b.dims[2] = 7;
  CHECK_THAT(grid_difference(a, b), Catch::Contains("dimensions 4x5x6 vs 4x5x7"));
  b = a;
  b.spacing[1] = 0.41;
  CHECK_THAT(grid_difference(a, b), Catch::Contains("spacing"));
  b = a;
  b.origin[2] = 31;
  CHECK_THAT(grid_difference(a, b), Catch::Contains("origin"));
  b = a;
  b.direction.col(1) *= -1;  // a flipped j axis, same origin
  CHECK_THAT(grid_difference(a, b), Catch::Contains("direction of axis 1"));
}

TEST_CASE("Volume view: reads and writes the caller's buffer; copies own theirs",
          "[core][volume]") {
  const VolumeGeometry g = oblique_geometry();
  std::vector<float> buffer(static_cast<std::size_t>(g.voxel_count()));
  for (std::size_t n = 0; n < buffer.size(); ++n) buffer[n] = static_cast<float>(n);
  Volume<float> view = Volume<float>::view(g, buffer.data());
  CHECK_FALSE(view.owns_data());
  CHECK(view.data() == buffer.data());
  CHECK(view.size() == buffer.size());
  // The same i-fastest order as an owning volume, in both directions.
  CHECK(view(1, 2, 1) == buffer[1 + 5 * (2 + 4 * 1)]);
  buffer[7] = -3.0f;
  CHECK(view(2, 1, 0) == -3.0f);
  view(4, 3, 2) = 99.0f;
  CHECK(buffer.back() == 99.0f);
  float sum = 0;
  for (const float v : view) sum += v;
  CHECK(sum == std::accumulate(buffer.begin(), buffer.end(), 0.0f));

  // A copy owns its voxels: later writes to the buffer do not reach it.
  const Volume<float> copy = view;
  CHECK(copy.owns_data());
  CHECK(copy.data() != buffer.data());
  buffer[0] = 42.0f;
  CHECK(copy(0, 0, 0) == 0.0f);
  CHECK(copy.storage().size() == buffer.size());
  // A moved view stays a view; the moved-from volume is empty.
  Volume<float> moved = std::move(view);
  CHECK_FALSE(moved.owns_data());
  CHECK(moved(0, 0, 0) == 42.0f);
  CHECK(view.size() == 0);  // NOLINT(bugprone-use-after-move): documented state
  // A moved owning volume keeps its buffer (no copy) and its ownership.
  Volume<float> owning(g, 1.0f);
  const float* address = owning.data();
  const Volume<float> taken = std::move(owning);
  CHECK(taken.owns_data());
  CHECK(taken.data() == address);
  // Assigning a view over an owning volume makes it a view.
  Volume<float> target(g, 0.0f);
  target = Volume<float>::view(g, buffer.data());
  CHECK(target.data() == buffer.data());

  // A view has no vector; its geometry and buffer are checked.
  CHECK_THROWS_WITH(moved.storage(), Catch::Contains("storage() of a view"));
  VolumeGeometry bad = g;
  bad.spacing[1] = 0;
  CHECK_THROWS_WITH(Volume<float>::view(bad, buffer.data()),
                    Catch::Contains("Volume view: spacing 1 must be in [1e-4, 1e4] mm, got 0"));
  // Finite but beyond any scanner: a 1e30 mm voxel failed later as a camera "beyond 1e9".
  bad = g;
  bad.spacing[0] = 1e30;
  CHECK_THROWS_WITH(Volume<float>::view(bad, buffer.data()),
                    Catch::Contains("spacing 0") && Catch::Contains("1e+30"));
  bad = g;
  bad.origin[2] = -1e12;
  CHECK_THROWS_WITH(Volume<float>::view(bad, buffer.data()),
                    Catch::Contains("origin 2") && Catch::Contains("-1e+12"));
  CHECK_THROWS_WITH(Volume<float>::view(g, nullptr), Catch::Contains("no buffer"));
}
