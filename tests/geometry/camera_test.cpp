// Camera: P = K [R | t], pixel centres at integers, rays, depth and in_front, orthographic P.
#include <Eigen/Geometry>
#include <catch2/catch.hpp>
#include <cmath>

#include "gimm/core/rng.hpp"
#include "gimm/geometry/camera.hpp"
#include "gimm/geometry/carm.hpp"

// Its own namespace: the tests are compiled as one file (tests/CMakeLists.txt).
namespace camera_test {

using namespace gimm;

namespace {

CArm pose(double primary, double secondary, ProjectionModel model) {
  CArm carm;
  carm.primary_deg = primary;
  carm.secondary_deg = secondary;
  carm.model = model;
  carm.isocenter = Eigen::Vector3d(4, -6, 10);
  carm.rows = 300;
  carm.cols = 400;
  return carm;
}

ProjectionModel any_model() {
  return GENERATE(ProjectionModel::perspective, ProjectionModel::orthographic);
}

Eigen::Vector3d random_point(Rng& rng, const Eigen::Vector3d& centre, double half) {
  return centre + Eigen::Vector3d(rng.uniform(-half, half), rng.uniform(-half, half),
                                  rng.uniform(-half, half));
}

double distance_to_ray(const Ray<double>& r, const Eigen::Vector3d& X) {
  const Eigen::Vector3d d = X - r.origin;
  return (d - d.dot(r.direction) * r.direction).norm();
}

}  // namespace

TEST_CASE("Camera K has a negative second focal entry (rows grow downwards)",
          "[geometry][camera]") {
  const ProjectionModel model = any_model();
  const Camerad camera = pose(25, 15, model).camera();
  const Eigen::Matrix3d& K = camera.K();
  CHECK(K(0, 0) > 0);
  CHECK(K(1, 1) == -K(0, 0));
  CHECK(K(0, 1) == 0);
  CHECK(K(2, 2) == 1);
  // Rows of R: image right, image up, source -> detector; right x up = forward (det +1).
  const Eigen::Vector3d right = camera.R().row(0), up = camera.R().row(1),
                        forward = camera.R().row(2);
  CHECK((right.cross(up) - forward).norm() < 1e-12);
  CHECK((forward - camera.principal_axis()).norm() == 0);
  // Moving along "up" decreases v; along "right" increases u.
  const Eigen::Vector3d iso(4, -6, 10);
  const auto p0 = camera.project(iso), pu = camera.project(iso + up),
             pr = camera.project(iso + right);
  CHECK(pu.uv.y() < p0.uv.y());
  CHECK(pu.uv.x() == Approx(p0.uv.x()));
  CHECK(pr.uv.x() > p0.uv.x());
  CHECK(pr.uv.y() == Approx(p0.uv.y()));
}

TEST_CASE("Camera P reproduces project(); orthographic P has last row (0, 0, 0, 1)",
          "[geometry][camera]") {
  const ProjectionModel model = any_model();
  const Camerad camera = pose(-35, 20, model).camera();
  const Eigen::Matrix<double, 3, 4> P = camera.P();
  if (model == ProjectionModel::orthographic) {
    CHECK(P.row(2) == Eigen::RowVector4d(0, 0, 0, 1));
  } else {
    Eigen::Matrix<double, 3, 4> Rt;
    Rt << camera.R(), camera.t();
    CHECK((P - camera.K() * Rt).norm() == 0);
    CHECK(P.block<1, 3>(2, 0).norm() == Approx(1));  // K's last row (0, 0, 1) times R
  }
  Rng rng(3);
  for (int n = 0; n < 50; ++n) {
    const Eigen::Vector3d X = random_point(rng, {4, -6, 10}, 80);
    const Eigen::Vector3d x = P * X.homogeneous();
    const auto p = camera.project(X);
    CHECK((x.hnormalized() - p.uv).norm() < 1e-9);
    CHECK(p.in_front);
  }
  // The homogeneous centre is P's right null vector: the source (perspective) or the
  // viewing direction at infinity (orthographic).
  const Eigen::Vector4d C = camera.center_homogeneous();
  CHECK((P * C).norm() < 1e-9 * P.norm());
  CHECK(C(3) == (model == ProjectionModel::perspective ? 1.0 : 0.0));
}

TEST_CASE("Camera center and depth", "[geometry][camera]") {
  const ProjectionModel model = any_model();
  const CArm carm = pose(50, -25, model);
  const Camerad camera = carm.camera();
  // Perspective: the source; orthographic: the virtual source point, at SOD from the isocentre
  // on the principal ray. Both give depth = SOD at the isocentre.
  CHECK((camera.center() - carm.source_position()).norm() < 1e-9);
  CHECK(camera.project(carm.isocenter).depth == Approx(750));
  CHECK(camera.project(camera.center()).depth == Approx(0).margin(1e-9));
  // Depth is measured along the principal axis in mm.
  const Eigen::Vector3d X = carm.isocenter + 30 * camera.principal_axis() +
                            12 * Eigen::Vector3d(camera.R().row(0).transpose());
  CHECK(camera.project(X).depth == Approx(780));
}

TEST_CASE("Camera: a point behind the source is flagged", "[geometry][camera]") {
  const ProjectionModel model = any_model();
  CArm carm;  // AP, isocentre at the origin
  carm.model = model;
  const Camerad camera = carm.camera();
  // AP: source at y = 750; y = 800 is behind it (further posterior), y = 749 just in front.
  const auto behind = camera.project(Eigen::Vector3d(10, 800, 5));
  CHECK_FALSE(behind.in_front);
  CHECK(behind.depth == Approx(-50));
  const auto at_source = camera.project(carm.source_position());
  CHECK_FALSE(at_source.in_front);
  const auto in_front = camera.project(Eigen::Vector3d(10, 749, 5));
  CHECK(in_front.in_front);
  CHECK(in_front.depth == Approx(1));
  if (model == ProjectionModel::perspective) {
    // The algebraic projection of a point behind the source is mirrored through the centre.
    const Eigen::Vector2d c = carm.principal_point_or_centre();
    CHECK(behind.uv.x() < c.x());
    CHECK(behind.uv.y() > c.y());
  }
}

TEST_CASE("Camera::ray passes back through the point that projects to (u, v)",
          "[geometry][camera]") {
  const ProjectionModel model = any_model();
  const CArm carm = pose(-20, 30, model);
  const Camerad camera = carm.camera();
  Rng rng(17);
  for (int n = 0; n < 100; ++n) {
    const Eigen::Vector3d X = random_point(rng, carm.isocenter, 90);
    const auto p = camera.project(X);
    const Ray<double> r = camera.ray(p.uv.x(), p.uv.y());
    CHECK(r.direction.norm() == Approx(1).epsilon(1e-14));
    CHECK(r.direction.dot(camera.principal_axis()) > 0);  // source -> detector
    CHECK(distance_to_ray(r, X) < 1e-9);
    const double s = (X - r.origin).dot(r.direction);
    CHECK(s > 0);
    // Perspective rays start at the source; orthographic rays at depth 0, parallel to the axis.
    if (model == ProjectionModel::perspective) {
      CHECK((r.origin - camera.center()).norm() < 1e-12);
      CHECK(s == Approx((X - camera.center()).norm()));
    } else {
      CHECK((r.direction - camera.principal_axis()).norm() < 1e-15);
      CHECK(camera.project(r.origin).depth == Approx(0).margin(1e-9));
      CHECK(s == Approx(p.depth));
    }
    // And the ray projects back to (u, v) all along its length.
    for (double t : {100.0, 700.0, 1200.0})
      CHECK((camera.project(r.origin + t * r.direction).uv - p.uv).norm() < 1e-8);
  }
}

TEST_CASE("Camera pixel centres are at integer (u, v) = (col, row)", "[geometry][camera]") {
  const ProjectionModel model = any_model();
  CArm carm;
  carm.rows = 4;
  carm.cols = 6;
  carm.model = model;
  const Camerad camera = carm.camera();
  // Principal point at the detector centre: ((cols - 1) / 2, (rows - 1) / 2) = (2.5, 1.5).
  CHECK(carm.principal_point_or_centre() == Eigen::Vector2d(2.5, 1.5));
  // The centres of opposite corner pixels (0, 0) and (5, 3) are symmetric about the axis.
  const Ray<double> a = camera.ray(0, 0), b = camera.ray(5, 3);
  const Eigen::Vector3d axis = camera.principal_axis();
  if (model == ProjectionModel::perspective) {
    CHECK((a.direction + b.direction - 2 * a.direction.dot(axis) * axis).norm() < 1e-12);
  } else {
    CHECK(((a.origin - camera.center()) + (b.origin - camera.center())).norm() < 1e-9);
  }
  // The detector spans [-0.5, cols - 0.5] x [-0.5, rows - 0.5].
  CHECK(camera.on_detector({-0.5, -0.5}));
  CHECK(camera.on_detector({5.5, 3.5}));
  CHECK(camera.on_detector({0, 0}));
  CHECK(camera.on_detector({5, 3}));
  CHECK_FALSE(camera.on_detector({-0.51, 1}));
  CHECK_FALSE(camera.on_detector({1, -0.51}));
  CHECK_FALSE(camera.on_detector({5.51, 1}));
  CHECK_FALSE(camera.on_detector({1, 3.51}));
  CHECK_FALSE(camera.on_detector({6, 1}));  // cols is one past the last pixel centre
  CHECK_FALSE(camera.on_detector({1, 4}));
  CHECK_FALSE(camera.on_detector({std::nan(""), 1}));
}

TEST_CASE("Camera constructor rejects invalid K, R, size", "[geometry][camera]") {
  using Catch::Matchers::Contains;
  const Camerad good = CArm{}.camera();
  const Eigen::Matrix3d K = good.K(), R = good.R();
  const Eigen::Vector3d t = good.t();
  const auto P = ProjectionModel::perspective;
  CHECK_NOTHROW(Camerad(P, K, R, t, 10, 20));
  CHECK_THROWS_WITH(Camerad(P, K, R, t, 0, 20), Contains("0 x 20"));
  CHECK_THROWS_WITH(Camerad(P, K, R, t, 10, -1), Contains("10 x -1"));
  Eigen::Matrix3d badK = K;
  badK(2, 0) = 0.1;
  CHECK_THROWS_WITH(Camerad(P, badK, R, t, 10, 20), Contains("upper triangular"));
  badK = K;
  badK(2, 2) = 2;
  CHECK_THROWS_AS(Camerad(P, badK, R, t, 10, 20), Error);
  badK = K;
  badK(0, 0) = 0;
  CHECK_THROWS_WITH(Camerad(P, badK, R, t, 10, 20), Contains("zero focal"));
  Eigen::Matrix3d tinyK = Eigen::Matrix3d::Identity();
  tinyK(0, 0) = 1e-12;
  CHECK_THROWS_WITH(Camerad(P, tinyK, R, t, 10, 20),
                    Contains("focal entries must be at least 1e-6") && Contains("1e-12"));
  tinyK(0, 0) = 1e-6;  // the smallest accepted
  CHECK_NOTHROW(Camerad(P, tinyK, R, t, 10, 20));
  // Finite but absurd: K = 1e308 failed much later ("share their centre"); now at the camera.
  badK = K;
  badK(0, 0) = 1e308;
  CHECK_THROWS_WITH(Camerad(P, badK, R, t, 10, 20), Contains("1e+308") && Contains("+-1e9"));
  CHECK_THROWS_WITH(Camerad(P, K, R, Eigen::Vector3d(0, 0, 2e9), 10, 20), Contains("2e+09"));
  badK = K;
  badK(0, 0) = 1e9;  // the bound itself is a camera
  CHECK_NOTHROW(Camerad(P, badK, R, t, 10, 20));
  Eigen::Matrix3d reflection = R;
  reflection.row(2) *= -1;  // orthonormal, det -1
  CHECK_THROWS_WITH(Camerad(P, K, reflection, t, 10, 20), Contains("rotation"));
  CHECK_THROWS_AS(Camerad(P, K, 1.01 * R, t, 10, 20), Error);
  Eigen::Vector3d bad_t = t;
  bad_t.y() = std::nan("");
  CHECK_THROWS_WITH(Camerad(P, K, R, bad_t, 10, 20), Contains("finite"));
}

TEST_CASE("Camera::cast keeps the projection", "[geometry][camera]") {
  const ProjectionModel model = any_model();
  const Camerad camera = pose(15, 10, model).camera();
  const Cameraf f = camera.cast<float>();
  CHECK(f.model() == model);
  CHECK(f.rows() == camera.rows());
  CHECK(f.cols() == camera.cols());
  const Eigen::Vector3d X(20, -30, 15);
  CHECK((f.project(X.cast<float>()).uv.cast<double>() - camera.project(X).uv).norm() < 1e-2);
  CHECK(std::string(to_string(model)) ==
        (model == ProjectionModel::perspective ? "perspective" : "orthographic"));
}

}  // namespace camera_test
