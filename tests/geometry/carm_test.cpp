// C-arm conventions (DICOM XA, patient LPS): each test fails if a convention is flipped.
//   AP (0/0): source posterior (+y), patient's left on the image right, head at the top.
//   primary > 0 (LAO): source towards the patient's right (-x); < 0 (RAO): towards the left.
//   secondary > 0 (cranial): source towards the feet (-z); < 0 (caudal): towards the head.
#include <catch2/catch.hpp>
#include <cmath>

#include "gimm/geometry/carm.hpp"

// Its own namespace: the tests are compiled as one file (tests/CMakeLists.txt).
namespace carm_test {

using namespace gimm;

namespace {

CArm pose(double primary, double secondary, ProjectionModel model = ProjectionModel::perspective) {
  CArm carm;
  carm.primary_deg = primary;
  carm.secondary_deg = secondary;
  carm.model = model;
  return carm;
}

ProjectionModel any_model() {
  return GENERATE(ProjectionModel::perspective, ProjectionModel::orthographic);
}

}  // namespace

TEST_CASE("C-arm defaults", "[geometry][carm]") {
  const CArm carm;
  CHECK(carm.primary_deg == 0);
  CHECK(carm.secondary_deg == 0);
  CHECK(carm.sid_mm == 1000);
  CHECK(carm.sod_mm == 750);
  CHECK(carm.rows == 512);
  CHECK(carm.cols == 512);
  CHECK(carm.pixel_mm == 0.5);
  CHECK(carm.model == ProjectionModel::perspective);
  CHECK(carm.isocenter == Eigen::Vector3d::Zero());
  CHECK(carm.principal_point_or_centre() == Eigen::Vector2d(255.5, 255.5));
  const Camerad camera = carm.camera();
  CHECK(camera.rows() == 512);
  CHECK(camera.cols() == 512);
  // 192 mm field at the isocentre: a point 96 mm off axis lands on the detector's outer edge.
  const auto edge = camera.project(Eigen::Vector3d(96, 0, 0));
  CHECK(edge.uv.x() == Approx(511.5).margin(1e-9));
  CHECK(camera.on_detector(edge.uv));
  CHECK_FALSE(camera.on_detector(camera.project(Eigen::Vector3d(96.1, 0, 0)).uv));
}

TEST_CASE("AP view: source posterior, left on the right, head at the top", "[geometry][carm]") {
  const ProjectionModel model = any_model();
  const CArm carm = pose(0, 0, model);
  const Camerad camera = carm.camera();
  // Source posterior: +y in LPS, at SOD from the isocentre.
  CHECK(carm.source_position().y() > 0);
  CHECK((carm.source_position() - Eigen::Vector3d(0, 750, 0)).norm() < 1e-12);
  CHECK((camera.center() - Eigen::Vector3d(0, 750, 0)).norm() < 1e-9);
  // The beam goes posterior -> anterior (detector anterior).
  CHECK((camera.principal_axis() - Eigen::Vector3d(0, -1, 0)).norm() < 1e-12);

  const Eigen::Vector2d c = carm.principal_point_or_centre();
  const auto iso = camera.project(Eigen::Vector3d::Zero());
  CHECK((iso.uv - c).norm() < 1e-9);
  // Patient's left (+x) projects to the image right (u > cu); right (-x) to the left.
  const auto left = camera.project(Eigen::Vector3d(20, 0, 0));
  const auto right = camera.project(Eigen::Vector3d(-20, 0, 0));
  CHECK(left.uv.x() > c.x() + 1);
  CHECK(right.uv.x() < c.x() - 1);
  CHECK(left.uv.y() == Approx(c.y()).margin(1e-9));
  // Head (+z) projects to the top (v < cv; rows grow downwards); feet to the bottom.
  const auto head = camera.project(Eigen::Vector3d(0, 0, 20));
  const auto feet = camera.project(Eigen::Vector3d(0, 0, -20));
  CHECK(head.uv.y() < c.y() - 1);
  CHECK(feet.uv.y() > c.y() + 1);
  CHECK(head.uv.x() == Approx(c.x()).margin(1e-9));
  // Anterior-posterior offsets stay on the principal ray.
  const auto anterior = camera.project(Eigen::Vector3d(0, -50, 0));
  CHECK((anterior.uv - c).norm() < 1e-9);
  CHECK(anterior.depth > iso.depth);  // further from the source
}

TEST_CASE("LAO moves the source to the patient's right, RAO to the left", "[geometry][carm]") {
  const ProjectionModel model = any_model();
  for (double angle : {10.0, 30.0, 60.0, 90.0}) {
    CAPTURE(angle);
    const CArm lao = pose(angle, 0, model), rao = pose(-angle, 0, model);
    CHECK(lao.source_position().x() < 0);
    CHECK(lao.camera().center().x() < 0);
    CHECK(rao.source_position().x() > 0);
    CHECK(rao.camera().center().x() > 0);
    // A rotation about the head-foot axis: no z component, still at SOD.
    CHECK(lao.source_position().z() == Approx(0).margin(1e-12));
    CHECK(lao.source_position().norm() == Approx(750));
    // The head stays at the top of the image for any primary angle.
    const Camerad camera = lao.camera();
    CHECK(camera.project(Eigen::Vector3d(0, 0, 20)).uv.y() < lao.principal_point_or_centre().y());
  }
  // LAO 90: source exactly at the patient's right.
  CHECK((pose(90, 0).source_position() - Eigen::Vector3d(-750, 0, 0)).norm() < 1e-9);
  CHECK((pose(-90, 0).source_position() - Eigen::Vector3d(750, 0, 0)).norm() < 1e-9);
}

TEST_CASE("Cranial moves the source towards the feet, caudal towards the head",
          "[geometry][carm]") {
  const ProjectionModel model = any_model();
  for (double angle : {5.0, 20.0, 40.0}) {
    CAPTURE(angle);
    const CArm cranial = pose(0, angle, model), caudal = pose(0, -angle, model);
    CHECK(cranial.source_position().z() < 0);
    CHECK(cranial.camera().center().z() < 0);
    CHECK(caudal.source_position().z() > 0);
    CHECK(caudal.camera().center().z() > 0);
    // Still posterior, no left-right component at primary 0.
    CHECK(cranial.source_position().y() > 0);
    CHECK(cranial.source_position().x() == Approx(0).margin(1e-12));
    // The patient's left stays on the image right for any secondary angle.
    const Camerad camera = cranial.camera();
    CHECK(camera.project(Eigen::Vector3d(20, 0, 0)).uv.x() >
          cranial.principal_point_or_centre().x());
  }
  // Combined LAO + cranial (the classic "spider" view): right and feet.
  const Eigen::Vector3d spider = pose(40, 30).source_position();
  CHECK(spider.x() < 0);
  CHECK(spider.z() < 0);
  CHECK(spider.y() > 0);
}

TEST_CASE("Source direction follows s(a, b) = (-sin a cos b, cos a cos b, -sin b)",
          "[geometry][carm]") {
  for (double a : {-120.0, -45.0, 0.0, 17.0, 90.0, 180.0})
    for (double b : {-40.0, -10.0, 0.0, 25.0, 60.0}) {
      CAPTURE(a, b);
      CArm carm = pose(a, b);
      carm.isocenter = Eigen::Vector3d(5, -7, 12);
      const double ar = deg_to_rad(a), br = deg_to_rad(b);
      const Eigen::Vector3d s(-std::sin(ar) * std::cos(br), std::cos(ar) * std::cos(br),
                              -std::sin(br));
      CHECK((carm.source_direction() - s).norm() < 1e-12);
      CHECK((carm.source_position() - (carm.isocenter + 750 * s)).norm() < 1e-9);
      // The camera looks from the source through the isocentre; R is a proper rotation.
      const Camerad camera = carm.camera();
      CHECK((camera.principal_axis() + s).norm() < 1e-12);
      CHECK(camera.R().determinant() == Approx(1));
      CHECK((camera.R() * camera.R().transpose() - Eigen::Matrix3d::Identity()).norm() < 1e-12);
      CHECK((camera.project(carm.isocenter).uv - carm.principal_point_or_centre()).norm() < 1e-9);
      CHECK(camera.project(carm.isocenter).depth == Approx(750));
    }
}

TEST_CASE("Magnification: isocentre offsets scale by SID / SOD / pixel", "[geometry][carm]") {
  CArm carm;
  carm.sid_mm = 1200;
  carm.sod_mm = 800;
  carm.pixel_mm = 0.3;
  carm.rows = 400;
  carm.cols = 600;
  const double px_per_mm = 1200.0 / 800.0 / 0.3;  // 5 px per mm at the isocentre
  const Eigen::Vector2d c(299.5, 199.5);
  REQUIRE(carm.principal_point_or_centre() == c);
  for (const ProjectionModel model :
       {ProjectionModel::perspective, ProjectionModel::orthographic}) {
    carm.model = model;
    const Camerad camera = carm.camera();
    for (double d : {-30.0, 1.0, 12.5}) {
      // AP: the isocentre plane is y = 0; x is image right, z is image up.
      const auto px = camera.project(Eigen::Vector3d(d, 0, 0));
      CHECK(px.uv.x() - c.x() == Approx(d * px_per_mm));
      CHECK(px.uv.y() == Approx(c.y()));
      const auto pz = camera.project(Eigen::Vector3d(0, 0, d));
      CHECK(c.y() - pz.uv.y() == Approx(d * px_per_mm));
      CHECK(pz.uv.x() == Approx(c.x()));
    }
    // Off the isocentre plane the models differ: perspective magnifies points nearer the
    // source (posterior, +y) more; orthographic does not depend on depth.
    const double near_source = camera.project(Eigen::Vector3d(10, 200, 0)).uv.x() - c.x();
    const double near_detector = camera.project(Eigen::Vector3d(10, -200, 0)).uv.x() - c.x();
    if (model == ProjectionModel::perspective) {
      CHECK(near_source == Approx(10 * 1200.0 / (800.0 - 200.0) / 0.3));
      CHECK(near_detector == Approx(10 * 1200.0 / (800.0 + 200.0) / 0.3));
    } else {
      CHECK(near_source == Approx(10 * px_per_mm));
      CHECK(near_detector == Approx(10 * px_per_mm));
    }
  }
}

TEST_CASE("Both models agree at the isocentre plane for any pose", "[geometry][carm]") {
  for (double a : {-30.0, 45.0})
    for (double b : {-20.0, 25.0}) {
      CArm persp = pose(a, b), ortho = pose(a, b, ProjectionModel::orthographic);
      persp.isocenter = ortho.isocenter = Eigen::Vector3d(3, 4, -5);
      const Camerad cp = persp.camera(), co = ortho.camera();
      // Points in the plane through the isocentre orthogonal to the principal axis.
      const Eigen::Matrix3d R = cp.R();
      for (const Eigen::Vector2d& offset :
           {Eigen::Vector2d(10, 0), Eigen::Vector2d(0, -15), Eigen::Vector2d(-7, 22)}) {
        const Eigen::Vector3d X =
            persp.isocenter + R.row(0).transpose() * offset.x() + R.row(1).transpose() * offset.y();
        CHECK((cp.project(X).uv - co.project(X).uv).norm() < 1e-9);
      }
    }
}

TEST_CASE("Principal point override and isocentre", "[geometry][carm]") {
  CArm carm = pose(20, -10);
  carm.principal_point = Eigen::Vector2d(240.25, 270.0);
  carm.isocenter = Eigen::Vector3d(-10, 25, 40);
  const Camerad camera = carm.camera();
  CHECK((camera.project(carm.isocenter).uv - Eigen::Vector2d(240.25, 270.0)).norm() < 1e-9);
  CHECK(camera.K()(0, 2) == 240.25);
  CHECK(camera.K()(1, 2) == 270.0);
  // K = [[f, 0, cu], [0, -f, cv], [0, 0, 1]], f = SID / pixel for perspective.
  CHECK(camera.K()(0, 0) == Approx(2000));
  CHECK(camera.K()(1, 1) == Approx(-2000));
  carm.model = ProjectionModel::orthographic;
  CHECK(carm.camera().K()(0, 0) == Approx(1000.0 / (0.5 * 750.0)));
  CHECK(carm.camera().K()(1, 1) == Approx(-1000.0 / (0.5 * 750.0)));
}

TEST_CASE("CArm::validate names the bad field and value", "[geometry][carm]") {
  using Catch::Matchers::Contains;
  CArm carm;
  REQUIRE_NOTHROW(carm.validate());
  carm = CArm{};
  carm.secondary_deg = 90;
  CHECK_THROWS_WITH(carm.camera(), Contains("secondary") && Contains("90"));
  carm = CArm{};
  carm.primary_deg = 181;
  CHECK_THROWS_WITH(carm.camera(), Contains("primary") && Contains("181"));
  carm = CArm{};
  carm.primary_deg = std::nan("");
  CHECK_THROWS_AS(carm.camera(), Error);
  carm = CArm{};
  carm.sid_mm = 700;
  CHECK_THROWS_WITH(carm.camera(), Contains("SID") && Contains("700"));
  carm = CArm{};
  carm.sod_mm = -1;
  CHECK_THROWS_WITH(carm.camera(), Contains("SOD") && Contains("-1"));
  carm = CArm{};
  carm.rows = 0;
  CHECK_THROWS_WITH(carm.camera(), Contains("0 x 512"));
  carm = CArm{};
  carm.pixel_mm = 0;
  CHECK_THROWS_WITH(carm.camera(), Contains("pixel"));
  carm = CArm{};
  carm.isocenter.x() = std::numeric_limits<double>::infinity();
  CHECK_THROWS_AS(carm.camera(), Error);
  carm = CArm{};
  carm.principal_point = Eigen::Vector2d(std::nan(""), 3);
  CHECK_THROWS_AS(carm.camera(), Error);
  // Finite but beyond any C-arm: refused here, naming the field (they made a camera whose K or
  // t is beyond 1e9, refused later without the flag's name).
  carm = CArm{};
  carm.pixel_mm = 1e-7;
  CHECK_THROWS_WITH(carm.camera(), Contains("pixel size") && Contains("1e-07"));
  carm = CArm{};
  carm.sod_mm = 1e8;
  carm.sid_mm = 1e9;
  CHECK_THROWS_WITH(carm.camera(), Contains("SOD") && Contains("1e+08"));
  carm = CArm{};
  carm.isocenter.x() = 1e12;
  CHECK_THROWS_WITH(carm.camera(), Contains("isocentre") && Contains("1e+12"));
  carm = CArm{};
  carm.table_mm.z() = -2e5;
  CHECK_THROWS_WITH(carm.camera(), Contains("table") && Contains("-200000"));
  carm = CArm{};
  carm.principal_point = Eigen::Vector2d(1e12, 3);
  CHECK_THROWS_WITH(carm.camera(), Contains("principal point") && Contains("1e+12"));
  carm = CArm{};
  carm.pixel_mm = CArm::kMinPixelMm;  // the bounds themselves make cameras
  carm.sid_mm = CArm::kMaxDistanceMm;
  carm.isocenter = Eigen::Vector3d::Constant(CArm::kMaxPositionMm);
  CHECK_NOTHROW(carm.camera());
  // The limits themselves are valid.
  CHECK_NOTHROW(pose(180, 89.9).camera());
  CHECK_NOTHROW(pose(-180, -89.9).camera());
}

TEST_CASE("CArm table: the patient rides on the table, the isocentre moves the other way",
          "[geometry]") {
  // HFS axes: lateral -> x, vertical -> y, longitudinal -> z (docs/conventions.md). The table
  // moved by (+1 lateral, -2 vertical, +5 longitudinal) carries the patient with it, so the
  // patient point now at the room's isocentre is the one that sat at -(1, -2, 5) = (-1, 2, -5):
  // by hand, that point projects to the image centre (the principal point) in any view, and the
  // old isocentre does not. Flip the sign or an axis and this fails.
  for (const auto& [primary, secondary] : {std::pair{0.0, 0.0}, {-30.0, 20.0}, {45.0, -25.0}}) {
    CArm moved = pose(primary, secondary);
    moved.reference_table_mm = {10, 20, 30};
    moved.table_mm = {11, 18, 35};
    const Camerad camera = moved.camera();
    const Eigen::Vector2d centre((moved.cols - 1) / 2.0, (moved.rows - 1) / 2.0);
    CHECK((camera.project(Eigen::Vector3d(-1, 2, -5)).uv - centre).norm() < 1e-9);
    CHECK((camera.project(Eigen::Vector3d(0, 0, 0)).uv - centre).norm() > 1.0);
    // ... and the point at the isocentre keeps its depth: the source is SOD from it.
    CHECK((moved.source_position() - Eigen::Vector3d(-1, 2, -5)).norm() == Approx(moved.sod_mm));
  }
  // Feet first: lateral and longitudinal turn round (the patient's left is the table's right),
  // vertical does not.
  CArm ffs = pose(0, 0);
  ffs.patient_position = PatientPosition::FFS;
  ffs.table_mm = {1, -2, 5};
  CHECK(ffs.table_shift() == Eigen::Vector3d(-1, -2, -5));
  CHECK(ffs.view_isocenter() == Eigen::Vector3d(1, 2, 5));
  // The same table as the reference: no move, whatever the absolute position.
  CArm same = pose(10, 0);
  same.table_mm = same.reference_table_mm = {100, -50, 900};
  CHECK(same.view_isocenter() == Eigen::Vector3d::Zero());
  same.table_mm.x() = std::nan("");
  CHECK_THROWS_WITH(same.camera(), Catch::Contains("table"));
}

TEST_CASE("CArm non-square pixels: each axis has its own focal length", "[geometry]") {
  CArm carm = pose(0, 0);
  carm.pixel_mm = 0.2;      // across the columns (u)
  carm.pixel_row_mm = 0.4;  // down the rows (v)
  const Camerad camera = carm.camera();
  CHECK(camera.K()(0, 0) == Approx(1000 / 0.2));
  CHECK(camera.K()(1, 1) == Approx(-1000 / 0.4));
  // A point 10 mm to the patient's left and 10 mm headwards at the isocentre (AP, magnification
  // 4/3): 66.7 px right of centre but only 33.3 px up.
  const Eigen::Vector2d c = carm.principal_point_or_centre();
  const Eigen::Vector2d uv = camera.project(Eigen::Vector3d(10, 0, 10)).uv;
  CHECK(uv.x() - c.x() == Approx(10 * 4.0 / 3 / 0.2));
  CHECK(c.y() - uv.y() == Approx(10 * 4.0 / 3 / 0.4));
  carm.pixel_row_mm = -1;
  CHECK_THROWS_WITH(carm.camera(), Catch::Contains("row pixel"));
}

}  // namespace carm_test
