// Pair labels on the phantom: every label reprojects with the pair's cameras to 1e-3 px and
// satisfies the exact epipolar constraint; validity filters; farthest-point sampling.
#include <catch2/catch.hpp>

#include "gimm/anatomy/components.hpp"
#include "gimm/anatomy/phantom.hpp"
#include "gimm/geometry/carm.hpp"
#include "gimm/labels/correspondence.hpp"
#include "gimm/render/drr.hpp"

namespace {

gimm::Camerad view(double primary, double secondary) {
  gimm::CArm c;
  c.primary_deg = primary;
  c.secondary_deg = secondary;
  c.rows = c.cols = 160;
  c.pixel_mm = 1.6;
  return c.camera();
}

}  // namespace

TEST_CASE("Pair labels reproject exactly and satisfy x_b^T F x_a = 0", "[labels]") {
  gimm::PhantomOptions o;
  o.seed = 11;
  o.noise_hu = 0;
  const auto phantom = gimm::make_phantom(o);
  const auto split = gimm::split_coronary_systems(phantom.label);
  const auto points = gimm::flatten_centerlines(phantom.centerlines, gimm::CoronarySystem::LCA);
  REQUIRE(points.size() > 500);
  const auto cam_a = view(40, 20), cam_b = view(-30, -20);
  const auto mask_a = gimm::project_mask(split.lca, cam_a);
  const auto mask_b = gimm::project_mask(split.lca, cam_b);
  const auto la = gimm::label_view(points, cam_a, &mask_a);
  const auto lb = gimm::label_view(points, cam_b, &mask_b);
  gimm::Rng rng(5);
  const auto pair = gimm::label_pair(points, la, lb, cam_a, cam_b, 20, rng);

  // Almost every LCA centerline point lies on its own projected mask in both views.
  CHECK(pair.dense.size() > 0.95 * points.size());
  CHECK(pair.sparse.size() == 20);
  for (const auto& c : pair.dense) {
    CHECK((cam_a.project(c.world).uv - c.a).norm() < 1e-3);
    CHECK((cam_b.project(c.world).uv - c.b).norm() < 1e-3);
    const double residual = c.b.homogeneous().dot(pair.F * c.a.homogeneous());
    CHECK(std::abs(residual) <= 1e-9 * c.a.homogeneous().norm() * c.b.homogeneous().norm());
    CHECK(c.radius > 0);
    CHECK(phantom.centerlines.branches[c.branch].points[c.index] == c.world);
  }
  // Only points valid in both views are kept.
  std::size_t both = 0;
  for (std::size_t n = 0; n < points.size(); ++n) both += la[n].valid() && lb[n].valid();
  CHECK(pair.dense.size() == both);
}

TEST_CASE("label_view: behind the source, off the detector, off the mask", "[labels]") {
  const auto cam = view(0, 0);
  std::vector<gimm::LabelPoint> pts(3);
  pts[0].world = Eigen::Vector3d(0, 0, 0);                     // isocentre: centre of the image
  pts[1].world = cam.center() + cam.principal_axis() * -10.0;  // behind the source
  pts[2].world = Eigen::Vector3d(400, 0, 0);                   // far off to the side
  gimm::Image<std::uint8_t> mask(160, 160, 0);
  const auto none = gimm::label_view(pts, cam, &mask);
  CHECK(none[0].in_image);
  CHECK_FALSE(none[0].on_mask);
  CHECK_FALSE(none[1].in_front);
  CHECK_FALSE(none[1].valid());
  CHECK_FALSE(none[2].in_image);
  mask(80, 80) = 1;  // the isocentre projects to the principal point (79.5, 79.5) -> (80, 80)
  CHECK(gimm::label_view(pts, cam, &mask)[0].on_mask);
  CHECK(none[0].depth == Approx(750));
  gimm::Image<std::uint8_t> wrong(10, 10, 0);
  CHECK_THROWS_WITH(gimm::label_view(pts, cam, &wrong), Catch::Contains("10 x 10"));
}

TEST_CASE("Farthest-point sampling picks the farthest point each time", "[labels]") {
  gimm::Rng rng(3);
  std::vector<Eigen::Vector3d> pts;
  for (int n = 0; n < 300; ++n)
    pts.emplace_back(rng.uniform(-50, 50), rng.uniform(-50, 50), rng.uniform(-50, 50));
  gimm::Rng seeded(9), again(9);
  const auto chosen = gimm::farthest_point_sampling(pts, 20, seeded);
  CHECK(chosen == gimm::farthest_point_sampling(pts, 20, again));
  REQUIRE(chosen.size() == 20);
  for (std::size_t k = 1; k < chosen.size(); ++k) {
    // Brute force: no point is farther from the chosen set than the one picked.
    auto dist_to_set = [&](std::size_t n) {
      double d = 1e300;
      for (std::size_t j = 0; j < k; ++j) d = std::min(d, (pts[n] - pts[chosen[j]]).norm());
      return d;
    };
    const double picked = dist_to_set(chosen[k]);
    for (std::size_t n = 0; n < pts.size(); ++n) REQUIRE(dist_to_set(n) <= picked + 1e-12);
  }
  CHECK(gimm::farthest_point_sampling(pts, 500, seeded).size() == 300);
  CHECK(gimm::farthest_point_sampling({}, 20, seeded).empty());
  const std::vector<Eigen::Vector3d> same(5, Eigen::Vector3d(1, 2, 3));
  CHECK(gimm::farthest_point_sampling(same, 3, seeded).size() == 1);
}
