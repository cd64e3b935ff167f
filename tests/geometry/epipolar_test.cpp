// Epipolar geometry: x_b^T F x_a = 0 with F from image A to image B, F from two cameras
// (perspective and orthographic), epipolar lines and the two squared pixel distances.
#include <catch2/catch.hpp>
#include <cmath>

#include "gimm/geometry/epipolar.hpp"
#include "scene.hpp"

using namespace gimm;
using gimm_test::carm_pose;

namespace {

/// F of a pure horizontal translation between two identical cameras: epipolar lines are the
/// image rows, x_b^T F x_a = s v_a - v_b (s = 1 for a plain translation; s != 1 scales rows).
Eigen::Matrix3d rows_F(double s = 1.0) {
  Eigen::Matrix3d F;
  F << 0, 0, 0,  //
      0, 0, -1,  //
      0, s, 0;
  return F;
}

}  // namespace

TEST_CASE("F from two perspective C-arm cameras satisfies x_b^T F x_a = 0",
          "[geometry][epipolar]") {
  const Camerad a = carm_pose(30, 20).camera(), b = carm_pose(-30, -15).camera();
  const Eigen::Matrix3d F = fundamental_from_cameras(a, b);
  const auto scene = gimm_test::make_pair_scene(a, b, 200, 1);
  CHECK(gimm_test::max_relative_residual(F, scene.x_a, scene.x_b) < 1e-9);
  CHECK(gimm_test::max_symmetric_sq(F, scene.x_a, scene.x_b) < 1e-12);
  // The direction matters: F^T (the B -> A matrix) does not fit these pairs.
  CHECK(gimm_test::max_symmetric_sq(F.transpose(), scene.x_a, scene.x_b) > 100);
  // The F from B to A is the transpose.
  const Eigen::Matrix3d F_ba = fundamental_from_cameras(b, a);
  CHECK((F_ba - normalize_fundamental(Eigen::Matrix3d(F.transpose()))).norm() < 1e-9);
  // Canonical form: unit Frobenius norm, largest-magnitude entry positive, rank 2.
  CHECK(F.norm() == Approx(1).epsilon(1e-12));
  Eigen::Index r = 0, c = 0;
  F.cwiseAbs().maxCoeff(&r, &c);
  CHECK(F(r, c) > 0);
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(F);
  CHECK(svd.singularValues()(2) < 1e-12 * svd.singularValues()(0));
  // The epipoles: the image of the other source; F e_a = 0 and F^T e_b = 0.
  const Eigen::Vector3d e_a = a.P() * b.center().homogeneous();
  const Eigen::Vector3d e_b = b.P() * a.center().homogeneous();
  CHECK((F * e_a).norm() < 1e-9 * e_a.norm());
  CHECK((F.transpose() * e_b).norm() < 1e-9 * e_b.norm());
}

TEST_CASE("F from cameras across poses, isocentres and detector sizes", "[geometry][epipolar]") {
  const double pa = GENERATE(-60.0, 0.0, 45.0);
  const double sb = GENERATE(-30.0, 25.0);
  CArm ca = carm_pose(pa, 10), cb = carm_pose(pa + 70, sb);
  ca.isocenter = Eigen::Vector3d(5, -20, 30);
  cb.isocenter = Eigen::Vector3d(-5, -15, 35);
  cb.rows = 256;
  cb.cols = 384;
  cb.pixel_mm = 0.8;
  const Camerad a = ca.camera(), b = cb.camera();
  const auto scene = gimm_test::make_pair_scene(a, b, 100, 7);
  const Eigen::Matrix3d F = fundamental_from_cameras(a, b);
  CHECK(gimm_test::max_relative_residual(F, scene.x_a, scene.x_b) < 1e-9);
}

TEST_CASE("F from two orthographic cameras is affine", "[geometry][epipolar]") {
  const Camerad a = carm_pose(30, 20, ProjectionModel::orthographic).camera();
  const Camerad b = carm_pose(-40, -10, ProjectionModel::orthographic).camera();
  const Eigen::Matrix3d F = fundamental_from_cameras(a, b);
  CHECK(F.topLeftCorner<2, 2>().cwiseAbs().maxCoeff() < 1e-12);
  CHECK(F.norm() == Approx(1).epsilon(1e-12));
  const auto scene = gimm_test::make_pair_scene(a, b, 200, 2);
  CHECK(gimm_test::max_relative_residual(F, scene.x_a, scene.x_b) < 1e-9);
  CHECK(gimm_test::max_symmetric_sq(F, scene.x_a, scene.x_b) < 1e-12);
  CHECK(gimm_test::max_symmetric_sq(F.transpose(), scene.x_a, scene.x_b) > 100);
  // Perspective pairs are not affine.
  const Eigen::Matrix3d Fp =
      fundamental_from_cameras(carm_pose(30, 20).camera(), carm_pose(-40, -10).camera());
  CHECK(Fp.topLeftCorner<2, 2>().cwiseAbs().maxCoeff() > 1e-6);
}

TEST_CASE("F from one perspective and one orthographic camera", "[geometry][epipolar]") {
  const Camerad a = carm_pose(20, 0).camera();
  const Camerad b = carm_pose(-50, 15, ProjectionModel::orthographic).camera();
  const auto scene = gimm_test::make_pair_scene(a, b, 100, 3);
  CHECK(gimm_test::max_relative_residual(fundamental_from_cameras(a, b), scene.x_a, scene.x_b) <
        1e-9);
  CHECK(gimm_test::max_relative_residual(fundamental_from_cameras(b, a), scene.x_b, scene.x_a) <
        1e-9);
}

TEST_CASE("F from cameras with no baseline throws", "[geometry][epipolar]") {
  // The same camera twice.
  const Camerad a = carm_pose(30, 20).camera();
  CHECK_THROWS_AS(fundamental_from_cameras(a, a), Error);
  // Same source, different detector (principal point): the centres coincide.
  CArm shifted = carm_pose(30, 20);
  shifted.principal_point = Eigen::Vector2d(200, 300);
  shifted.pixel_mm = 0.3;
  CHECK_THROWS_WITH(fundamental_from_cameras(a, shifted.camera()),
                    Catch::Matchers::Contains("share their centre"));
  // Orthographic: the same viewing direction (even from another isocentre), or the opposite.
  CArm o1 = carm_pose(10, 5, ProjectionModel::orthographic);
  CArm o2 = o1;
  o2.isocenter = Eigen::Vector3d(20, 0, -10);
  CHECK_THROWS_AS(fundamental_from_cameras(o1.camera(), o2.camera()), Error);
  CHECK_THROWS_AS(
      fundamental_from_cameras(carm_pose(0, 0, ProjectionModel::orthographic).camera(),
                               carm_pose(180, 0, ProjectionModel::orthographic).camera()),
      Error);
}

TEST_CASE("Epipolar lines and point-line distance", "[geometry][epipolar]") {
  const Eigen::Matrix3d F = rows_F();
  const Eigen::Vector2d x_a(10, 20), x_b(30, 23);
  const Eigen::Vector3d lb = epipolar_line_b<double>(F, x_a);  // the row v = 20 in B
  const Eigen::Vector3d la = epipolar_line_a<double>(F, x_b);  // the row v = 23 in A
  CHECK(point_line_distance<double>(lb, Eigen::Vector2d(123, 20)) == Approx(0).margin(1e-15));
  CHECK(point_line_distance<double>(lb, x_b) == Approx(3));
  CHECK(point_line_distance<double>(la, x_a) == Approx(3));
  CHECK(point_line_distance<double>(la, Eigen::Vector2d(-5, 23)) == Approx(0).margin(1e-15));
  // Scale invariant; infinite for a line without direction.
  CHECK(point_line_distance<double>(Eigen::Vector3d(4 * lb), x_b) == Approx(3));
  CHECK(std::isinf(point_line_distance<double>(Eigen::Vector3d(0, 0, 1), x_b)));
  // Line through two points, distance from a third.
  const Eigen::Vector3d l = Eigen::Vector3d(0, 0, 1).cross(Eigen::Vector3d(3, 4, 1));
  CHECK(point_line_distance<double>(l, Eigen::Vector2d(4, -3)) == Approx(5));
}

TEST_CASE("Symmetric and Sampson distances on a hand-computed case", "[geometry][epipolar]") {
  SECTION("pure horizontal translation: rows are epipolar lines") {
    const Eigen::Matrix3d F = rows_F();
    const Eigen::Vector2d x_a(10, 20), x_b(30, 23);
    // x_b^T F x_a = v_a - v_b = -3; both lines have unit normals (0, -+1).
    // symmetric: 3^2 + 3^2 = 18; Sampson: 9 / (1 + 1) = 4.5.
    CHECK(symmetric_epipolar_distance_sq<double>(F, x_a, x_b) == Approx(18));
    CHECK(sampson_distance_sq<double>(F, x_a, x_b) == Approx(4.5));
    // Same row: zero wherever the points are along it.
    CHECK(symmetric_epipolar_distance_sq<double>(F, x_a, Eigen::Vector2d(-400, 20)) == 0);
    CHECK(sampson_distance_sq<double>(F, x_a, Eigen::Vector2d(-400, 20)) == 0);
    // Defined up to scale: the same for -7 F.
    const Eigen::Matrix3d G = -7 * F;
    CHECK(symmetric_epipolar_distance_sq<double>(G, x_a, x_b) == Approx(18));
    CHECK(sampson_distance_sq<double>(G, x_a, x_b) == Approx(4.5));
  }
  SECTION("rows scaled by 2: the two lines have different normals") {
    // l_b = (0, -1, 2 v_a): the row v = 40 in B. l_a = (0, 2, -v_b): the row v = v_b / 2 in A.
    const Eigen::Matrix3d F = rows_F(2.0);
    const Eigen::Vector2d x_a(10, 20), x_b(30, 37);
    // r = 2 * 20 - 37 = 3; d(x_b, l_b) = 3, d(x_a, l_a) = |20 - 18.5| = 1.5.
    // symmetric: 3^2 + 1.5^2 = 11.25 = 9 (1/1 + 1/4); Sampson: 9 / (1 + 4) = 1.8.
    CHECK(symmetric_epipolar_distance_sq<double>(F, x_a, x_b) == Approx(11.25));
    CHECK(sampson_distance_sq<double>(F, x_a, x_b) == Approx(1.8));
    const double da = point_line_distance<double>(epipolar_line_a<double>(F, x_b), x_a);
    const double db = point_line_distance<double>(epipolar_line_b<double>(F, x_a), x_b);
    CHECK(da * da + db * db == Approx(11.25));
    // Swapping the images (F^T, x_b <-> x_a) gives the same distances.
    const Eigen::Matrix3d Ft = F.transpose();
    CHECK(symmetric_epipolar_distance_sq<double>(Ft, x_b, x_a) == Approx(11.25));
    CHECK(sampson_distance_sq<double>(Ft, x_b, x_a) == Approx(1.8));
    // Using F in the wrong direction gives another (wrong) value: the convention is tested.
    CHECK(symmetric_epipolar_distance_sq<double>(F, x_b, x_a) != Approx(11.25));
  }
  SECTION("a point at the epipole has no epipolar line: infinite distance") {
    const Eigen::Vector3d e(100, 50, 1);
    const Eigen::Matrix3d F = skew<double>(e);  // F e = 0
    const Eigen::Vector2d x_a(100, 50), x_b(10, 10);
    CHECK(std::isinf(symmetric_epipolar_distance_sq<double>(F, x_a, x_b)));
    // Sampson's denominator still has the line in A.
    CHECK(std::isfinite(sampson_distance_sq<double>(F, x_a, x_b)));
    CHECK(std::isinf(sampson_distance_sq<double>(Eigen::Matrix3d::Zero().eval(), x_a, x_b)));
  }
  SECTION("float works too") {
    const Eigen::Matrix3f F = rows_F().cast<float>();
    CHECK(symmetric_epipolar_distance_sq<float>(F, Eigen::Vector2f(10, 20),
                                                Eigen::Vector2f(30, 23)) == Approx(18));
  }
}

TEST_CASE("normalize_fundamental: unit norm, largest entry positive", "[geometry][epipolar]") {
  Eigen::Matrix3d F;
  F << 1, -2, 0.5,  //
      3, -8, 1,     //
      0, 2, 0;
  const Eigen::Matrix3d N = normalize_fundamental(F);
  CHECK(N.norm() == Approx(1));
  CHECK(N(1, 1) > 0);  // -8 was the largest magnitude
  CHECK((N + F / F.norm()).norm() < 1e-15);
  CHECK((normalize_fundamental(Eigen::Matrix3d(-3 * F)) - N).norm() < 1e-15);
  CHECK_THROWS_AS(normalize_fundamental(Eigen::Matrix3d::Zero()), Error);
  Eigen::Matrix3d nan_F = F;
  nan_F(0, 0) = std::nan("");
  CHECK_THROWS_AS(normalize_fundamental(nan_F), Error);
}
