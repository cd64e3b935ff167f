// Landmark alignment (geometry/landmark_alignment.hpp): B's C-arm moved onto landmarks marked in
// both views. The sign and the size of the shift against a case worked by hand; with two or more
// landmarks every epipolar line of the scene right again; refusals named.
#include <catch2/catch.hpp>
#include <vector>

#include "gimm/geometry/landmark_alignment.hpp"
#include "scene.hpp"

using gimm::Camerad;

namespace {

Eigen::Matrix3d focal_1000() {
  Eigen::Matrix3d K;
  K << 1000, 0, 255.5, 0, 1000, 255.5, 0, 0, 1;
  return K;
}

/// The epipolar distance in B of each scene point's B pixel from the line of its A pixel, px.
double worst_distance(const Camerad& a, const Camerad& b_used, const Camerad& b_true,
                      const std::vector<Eigen::Vector3d>& world) {
  const Eigen::Matrix3d F = gimm::fundamental_from_cameras(a, b_used);
  double worst = 0;
  for (const Eigen::Vector3d& X : world)
    worst = std::max(worst, gimm::point_line_distance(gimm::epipolar_line_b(F, a.project(X).uv),
                                                      b_true.project(X).uv));
  return worst;
}

}  // namespace

TEST_CASE("Landmark alignment: one landmark, worked by hand", "[geometry]") {
  // A looks along +z from (0, 0, -1000); B along +x from (-1000, 0, 0) (camera x = -z, y = +y).
  // The landmark is the world origin, at A's centre pixel. In the real B geometry the C-arm sits
  // 5 mm lower (-y) than B's camera says, so the origin shows 5 px further down (+v) in B:
  // (255.5, 260.5). Given B's ray through that pixel crosses x = 0 at y = +5, 5 mm from A's ray
  // (the z axis); the plane through both sources and the z axis is y = 0, seen in B as the row
  // v = 255.5: the landmark is 5 px off it. Closing the gap moves B by (0, -5, 0), up to the
  // tilt of the rays' common normal v = d_A x d_B ~ (-0.005, 1, 0) (B's ray rises 5 in 1000):
  // the shift is v (v . (C_A - C_B)) / |v|^2 = -5 v / |v|^2.
  Eigen::Matrix3d Ra = Eigen::Matrix3d::Identity(), Rb;
  Rb << 0, 0, -1, 0, 1, 0, 1, 0, 0;
  const Camerad a(gimm::ProjectionModel::perspective, focal_1000(), Ra, {0, 0, 1000}, 512, 512);
  const Camerad b(gimm::ProjectionModel::perspective, focal_1000(), Rb, {0, 0, 1000}, 512, 512);
  REQUIRE(a.center().isApprox(Eigen::Vector3d(0, 0, -1000)));
  REQUIRE(b.center().isApprox(Eigen::Vector3d(-1000, 0, 0)));
  const gimm::LandmarkAlignment r =
      gimm::align_to_landmarks(a, b, {{255.5, 255.5}}, {{255.5, 260.5}});
  const Eigen::Vector3d v(-0.005, 1, 0);
  const Eigen::Vector3d expected = -5 * v / v.squaredNorm();
  CHECK((r.shift_mm - expected).norm() < 1e-9);
  CHECK(r.constrained_directions == 1);
  CHECK(r.distance_before_px[0] == Approx(5.0).epsilon(1e-9));
  CHECK(r.distance_after_px[0] < 1e-6);  // a reversed sign would leave it 10 px off
  CHECK(r.camera_b.center().isApprox(b.center() + expected));
  CHECK(r.camera_b.R().isApprox(b.R()));
  CHECK(r.camera_b.K().isApprox(b.K()));
}

TEST_CASE("Landmark alignment: two or more landmarks put every epipolar line right", "[geometry]") {
  const Camerad a = gimm_test::carm_pose(-30, 20).camera();
  const Camerad b_true = gimm_test::carm_pose(40, -25).camera();
  const Eigen::Vector3d moved(4, -7, 3);  // the table moved by -moved between the runs
  const Camerad b_given =
      gimm::moved_camera(b_true, Eigen::Vector3d::Zero(), Eigen::Matrix3d::Identity(), -moved);
  const gimm_test::PairScene scene = gimm_test::make_pair_scene(a, b_true, 40, 3);
  REQUIRE(worst_distance(a, b_given, b_true, scene.world) > 10);
  // The shift along the baseline moves no epipolar plane: the true shift less that component.
  const Eigen::Vector3d baseline = (b_true.center() - a.center()).normalized();
  const Eigen::Vector3d seen = moved - baseline * baseline.dot(moved);
  for (int landmarks : {2, 3, 8}) {
    INFO(landmarks << " landmarks");
    std::vector<Eigen::Vector2d> pa, pb;
    for (int i = 0; i < landmarks; ++i) {
      pa.push_back(scene.x_a.col(i));
      pb.push_back(scene.x_b.col(i));
    }
    const gimm::LandmarkAlignment r = gimm::align_to_landmarks(a, b_given, pa, pb);
    CHECK(r.constrained_directions == 2);
    CHECK((r.shift_mm - seen).norm() < 1e-6);
    CHECK(std::abs(r.shift_mm.dot(baseline)) < 1e-9);
    for (double d : r.distance_after_px) CHECK(d < 1e-6);
    CHECK(worst_distance(a, r.camera_b, b_true, scene.world) < 1e-6);  // the 32+ held out too
  }
  // One landmark closes its own gap and most of the others'.
  const gimm::LandmarkAlignment one =
      gimm::align_to_landmarks(a, b_given, {scene.x_a.col(0)}, {scene.x_b.col(0)});
  CHECK(one.constrained_directions == 1);
  CHECK(one.distance_after_px[0] < 1e-6);
  CHECK(worst_distance(a, one.camera_b, b_true, scene.world) <
        0.5 * worst_distance(a, b_given, b_true, scene.world));
}

TEST_CASE("Landmark alignment: refusals name what is wrong", "[geometry]") {
  const Camerad a = gimm_test::carm_pose(-30, 20).camera();
  const Camerad b = gimm_test::carm_pose(40, -25).camera();
  const Eigen::Vector2d c(255.5, 255.5);
  CHECK_THROWS_WITH(gimm::align_to_landmarks(a, b, {}, {}), Catch::Contains("got 0 in A and 0"));
  CHECK_THROWS_WITH(gimm::align_to_landmarks(a, b, {c, c}, {c}),
                    Catch::Contains("got 2 in A and 1 in B"));
  CHECK_THROWS_WITH(gimm::align_to_landmarks(a, b, {c}, {{600, 10}}),
                    Catch::Contains("landmark 1") && Catch::Contains("not on both detectors"));
  CHECK_THROWS_WITH(gimm::align_to_landmarks(a, b, {c}, {{NAN, 10}}),
                    Catch::Contains("not on both detectors"));
  const Camerad ortho = gimm_test::carm_pose(40, -25, gimm::ProjectionModel::orthographic).camera();
  CHECK_THROWS_WITH(gimm::align_to_landmarks(a, ortho, {c}, {c}), Catch::Contains("perspective"));
}
