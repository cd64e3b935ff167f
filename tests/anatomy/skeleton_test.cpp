// Distance transform against brute force, simple-point test, thinning of known shapes, and
// centerlines of the phantom against its analytic centerlines.
#include <catch2/catch.hpp>

#include "gimm/anatomy/components.hpp"
#include "gimm/anatomy/phantom.hpp"
#include "gimm/anatomy/skeleton.hpp"
#include "gimm/core/rng.hpp"

namespace {

gimm::VolumeGeometry grid(int nx, int ny, int nz, Eigen::Vector3d spacing = {1, 1, 1}) {
  gimm::VolumeGeometry g;
  g.dims = {nx, ny, nz};
  g.spacing = spacing;
  return g;
}

}  // namespace

TEST_CASE("Distance transform equals brute force on an anisotropic random mask",
          "[anatomy][skeleton]") {
  gimm::Volume<std::uint8_t> mask(grid(13, 9, 7, {0.7, 1.1, 1.9}), 0);
  gimm::Rng rng(4);
  for (auto& v : mask.storage()) v = rng.uniform(0, 1) < 0.8;
  const auto d = gimm::distance_to_background(mask);
  for (int k = 0; k < 7; ++k)
    for (int j = 0; j < 9; ++j)
      for (int i = 0; i < 13; ++i) {
        double best = 1e300;
        for (int c = 0; c < 7; ++c)
          for (int b = 0; b < 9; ++b)
            for (int a = 0; a < 13; ++a)
              if (!mask(a, b, c))
                best = std::min(best, (mask.index_to_world(Eigen::Vector3d(a, b, c)) -
                                       mask.index_to_world(Eigen::Vector3d(i, j, k)))
                                          .norm());
        REQUIRE(d(i, j, k) == Approx(best).epsilon(1e-6));
      }
}

TEST_CASE("Simple points", "[anatomy][skeleton]") {
  auto bit = [](int x, int y, int z) { return 1u << ((x + 1) + 3 * (y + 1) + 9 * (z + 1)); };
  // The middle of a straight line is not simple (deleting it cuts the line).
  CHECK_FALSE(gimm::detail::is_simple(bit(-1, 0, 0) | bit(1, 0, 0)));
  // The end of a line is simple.
  CHECK(gimm::detail::is_simple(bit(-1, 0, 0)));
  // A voxel on a flat face of a full block is simple; the centre of a full cube is not
  // (deleting it makes a cavity).
  std::uint32_t below = 0;
  for (int x = -1; x <= 1; ++x)
    for (int y = -1; y <= 1; ++y)
      for (int z = -1; z <= 0; ++z) below |= bit(x, y, z);
  CHECK(gimm::detail::is_simple(below));
  CHECK_FALSE(gimm::detail::is_simple(0x7ffffff));
  // An isolated voxel is not simple (deleting it removes a component).
  CHECK_FALSE(gimm::detail::is_simple(0));
}

TEST_CASE("A thick straight tube thins to one line through its axis", "[anatomy][skeleton]") {
  gimm::Volume<std::uint8_t> mask(grid(40, 15, 15), 0);
  for (int k = 0; k < 15; ++k)
    for (int j = 0; j < 15; ++j)
      for (int i = 5; i < 35; ++i) mask(i, j, k) = std::hypot(j - 7, k - 7) <= 4.0;
  const auto tree = gimm::extract_centerlines(mask);
  REQUIRE(tree.branches.size() == 1);
  const auto& b = tree.branches[0];
  CHECK(b.length() > 20);
  for (std::size_t n = 0; n < b.points.size(); ++n) {
    CHECK(std::hypot(b.points[n].y() - 7, b.points[n].z() - 7) <= 1.0);
    if (n > 2 && n + 3 < b.points.size()) CHECK(b.radii[n] == Approx(4.0).margin(0.8));
  }
  // A ring keeps its hole: thinning preserves topology (one cycle survives).
  gimm::Volume<std::uint8_t> ring(grid(30, 30, 7), 0);
  for (int k = 1; k < 6; ++k)
    for (int j = 0; j < 30; ++j)
      for (int i = 0; i < 30; ++i) {
        const double r = std::hypot(i - 14.5, j - 14.5);
        ring(i, j, k) = r > 8 && r < 13;
      }
  const auto skel = gimm::thin(ring, gimm::distance_to_background(ring));
  int count = 0;
  for (auto v : skel.storage()) count += v;
  CHECK(count > 40);  // a closed curve of radius ~10.5 voxels
  CHECK(gimm::connected_components(skel).count() == 1);
  CHECK_THROWS_WITH(gimm::extract_centerlines(gimm::Volume<std::uint8_t>(grid(5, 5, 5), 0)),
                    Catch::Contains("empty"));
}

TEST_CASE("Phantom centerlines from the mask agree with the analytic ones", "[anatomy][skeleton]") {
  gimm::PhantomOptions o;
  o.seed = 2;
  o.noise_hu = 0;
  gimm::VolumeGeometry g;  // 0.6 mm over the heart
  g.dims = {240, 240, 200};
  g.spacing = {0.6, 0.6, 0.6};
  for (int a = 0; a < 3; ++a) g.origin[a] = -0.5 * (g.dims[a] - 1) * g.spacing[a];
  o.grid = g;
  const auto phantom = gimm::make_phantom(o);
  const auto split = gimm::split_coronary_systems(phantom.label);
  gimm::SkeletonOptions so;
  so.system = gimm::CoronarySystem::LCA;
  const auto lca = gimm::extract_centerlines(split.lca, so, "phantom LCA");
  gimm::CenterlineTree truth;
  for (const auto& b : phantom.centerlines.branches)
    if (b.system == gimm::CoronarySystem::LCA) truth.branches.push_back(b);
  for (auto& b : truth.branches) b.parent = -1;
  const auto c = gimm::compare_centerlines(lca, truth, 1.5);
  INFO("mean " << c.mean_distance_mm << " truth-side " << c.mean_truth_distance_mm << " spurious "
               << c.spurious_length_mm << " / " << c.extracted_length_mm << " missed "
               << c.missed_length_mm << " / " << c.truth_length_mm);
  CHECK(c.mean_distance_mm < 0.5);
  CHECK(c.mean_truth_distance_mm < 0.8);
  CHECK(c.spurious_length_mm < 0.05 * c.extracted_length_mm);
  CHECK(c.missed_length_mm < 0.05 * c.truth_length_mm);
  // Root at the ostium: the first point of the first branch is near the LM's start.
  CHECK((lca.branches[0].points.front() - truth.branches[0].points.front()).norm() < 3.0);
}
