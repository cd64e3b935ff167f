// Triangulation: DLT and midpoint recover world points from exact pixels in 2 or more views
// (perspective, orthographic, mixed); invalid input throws, degenerate geometry is nullopt.
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>

#include "gimm/geometry/triangulation.hpp"
#include "scene.hpp"

using namespace gimm;
using Catch::Matchers::Contains;
using gimm_test::carm_pose;

namespace {

using Pixels = std::vector<Eigen::Vector2d>;

Pixels project_all(const std::vector<Camerad>& cameras, const Eigen::Vector3d& X) {
  Pixels out;
  for (const auto& c : cameras) out.push_back(c.project(X).uv);
  return out;
}

std::vector<Camerad> views(const std::string& which) {
  using PM = ProjectionModel;
  if (which == "perspective 2") return {carm_pose(30, 20).camera(), carm_pose(-30, -15).camera()};
  if (which == "perspective 3")
    return {carm_pose(30, 20).camera(), carm_pose(-30, -15).camera(), carm_pose(0, 40).camera()};
  if (which == "orthographic 2")
    return {carm_pose(30, 20, PM::orthographic).camera(),
            carm_pose(-45, -15, PM::orthographic).camera()};
  if (which == "orthographic 3")
    return {carm_pose(30, 20, PM::orthographic).camera(),
            carm_pose(-45, -15, PM::orthographic).camera(),
            carm_pose(90, 0, PM::orthographic).camera()};
  return {carm_pose(30, 20).camera(), carm_pose(-45, -15, PM::orthographic).camera()};  // mixed
}

}  // namespace

TEST_CASE("Triangulation recovers exact points to 1e-6 mm", "[geometry][triangulation]") {
  const std::string which =
      GENERATE("perspective 2", "perspective 3", "orthographic 2", "orthographic 3", "mixed");
  CAPTURE(which);
  const auto cameras = views(which);
  Rng rng(3);
  for (int n = 0; n < 50; ++n) {
    const Eigen::Vector3d X(rng.uniform(-80, 80), rng.uniform(-80, 80), rng.uniform(-80, 80));
    const Pixels px = project_all(cameras, X);
    const auto dlt = triangulate_dlt(cameras, px);
    const auto mid = triangulate_midpoint(cameras, px);
    REQUIRE(dlt);
    REQUIRE(mid);
    CHECK((*dlt - X).norm() < 1e-6);
    CHECK((*mid - X).norm() < 1e-6);
    for (std::size_t v = 0; v < cameras.size(); ++v) {
      CHECK(reprojection_error(cameras[v], *dlt, px[v]) < 1e-6);
      CHECK(reprojection_error(cameras[v], *mid, px[v]) < 1e-6);
    }
  }
}

TEST_CASE("Two-view midpoint is the midpoint of the common perpendicular",
          "[geometry][triangulation]") {
  const auto cameras = views("perspective 2");
  const Eigen::Vector3d X(10, -20, 30);
  Pixels px = project_all(cameras, X);
  px[1] += Eigen::Vector2d(8.0, -6.0);  // skew rays
  const auto mid = triangulate_midpoint(cameras, px);
  REQUIRE(mid);
  // Closest points of the two rays, in closed form.
  const auto r0 = cameras[0].ray(px[0].x(), px[0].y()), r1 = cameras[1].ray(px[1].x(), px[1].y());
  const Eigen::Vector3d w = r0.origin - r1.origin;
  const double b = r0.direction.dot(r1.direction), d = r0.direction.dot(w), e = r1.direction.dot(w);
  const double s = (b * e - d) / (1 - b * b), t = (e - b * d) / (1 - b * b);
  const Eigen::Vector3d p0 = r0.origin + s * r0.direction, p1 = r1.origin + t * r1.direction;
  CHECK((p1 - p0).dot(r0.direction) == Approx(0).margin(1e-9));
  CHECK((p1 - p0).dot(r1.direction) == Approx(0).margin(1e-9));
  CHECK(((p0 + p1) / 2 - *mid).norm() < 1e-8);
  CHECK((p1 - p0).norm() > 0.1);  // really skew
  // With noise the reprojection error is no longer zero, but small.
  const auto dlt = triangulate_dlt(cameras, px);
  REQUIRE(dlt);
  CHECK(reprojection_error(cameras[1], *dlt, px[1]) > 0.1);
  CHECK(reprojection_error(cameras[1], *dlt, px[1]) < 10.0);
}

TEST_CASE("Triangulation invalid input throws", "[geometry][triangulation]") {
  const auto cameras = views("perspective 2");
  const Pixels px = project_all(cameras, Eigen::Vector3d(1, 2, 3));
  const std::vector<Camerad> one{cameras[0]};
  CHECK_THROWS_WITH(triangulate_dlt(one, Pixels{px[0]}),
                    Contains("triangulate_dlt") && Contains("at least 2 views, got 1"));
  CHECK_THROWS_WITH(triangulate_midpoint(one, Pixels{px[0]}),
                    Contains("triangulate_midpoint") && Contains("got 1"));
  CHECK_THROWS_WITH(triangulate_dlt(cameras, Pixels{px[0]}), Contains("2 cameras but 1 pixels"));
  Pixels nan_px = px;
  nan_px[1].y() = std::numeric_limits<double>::quiet_NaN();
  CHECK_THROWS_WITH(triangulate_dlt(cameras, nan_px), Contains("view 1"));
  CHECK_THROWS_AS(triangulate_midpoint(cameras, nan_px), Error);
}

TEST_CASE("Triangulation degenerate geometry returns nullopt", "[geometry][triangulation]") {
  SECTION("the same camera twice: one ray") {
    const Camerad c = carm_pose(20, 10).camera();
    const std::vector<Camerad> cameras{c, c};
    const Pixels px = project_all(cameras, Eigen::Vector3d(5, 5, 5));
    CHECK_FALSE(triangulate_dlt(cameras, px));
    CHECK_FALSE(triangulate_midpoint(cameras, px));
  }
  SECTION("two orthographic views along the same direction: parallel rays") {
    CArm o = carm_pose(20, 10, ProjectionModel::orthographic);
    CArm shifted = o;
    shifted.isocenter = Eigen::Vector3d(10, 0, 0);
    const std::vector<Camerad> cameras{o.camera(), shifted.camera()};
    const Pixels px = project_all(cameras, Eigen::Vector3d(5, 5, 5));
    CHECK_FALSE(triangulate_dlt(cameras, px));
    CHECK_FALSE(triangulate_midpoint(cameras, px));
  }
}

TEST_CASE("reprojection_error", "[geometry][triangulation]") {
  const Camerad c = CArm{}.camera();  // AP, source at y = 750
  const Eigen::Vector3d X(10, 0, 20);
  const Eigen::Vector2d uv = c.project(X).uv;
  CHECK(reprojection_error(c, X, uv) == 0);
  CHECK(reprojection_error(c, X, Eigen::Vector2d(uv + Eigen::Vector2d(3, 4))) == Approx(5));
  // Behind the source: infinite, even where the algebraic projection matches.
  const Eigen::Vector3d behind(10, 900, 20);
  CHECK(std::isinf(reprojection_error(c, behind, c.project(behind).uv)));
}
