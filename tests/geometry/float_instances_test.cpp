// The geometry's templates in float: gimm's own binaries compile the double instances once
// (src/instances/, extern elsewhere), so float is what a consumer instantiates from the headers
// alone. Each function compiles for float and agrees with its double answer to float precision.
// Not here: RANSAC and the DLT in float, whose instantiation alone took 34 s of compiling (58
// against 24 s for this file): too dear for the README's test command (docs/performance.md).
#include <catch2/catch.hpp>
#include <vector>

#include "gimm/geometry/carm.hpp"
#include "gimm/geometry/eight_point.hpp"
#include "gimm/geometry/epipolar.hpp"
#include "gimm/geometry/gating.hpp"
#include "gimm/geometry/triangulation.hpp"

namespace {

struct Scene {
  gimm::Camerad a, b;
  gimm::Points2<double> xa, xb;
  std::vector<Eigen::Vector3d> world;
};

/// 60 points of a 40 mm cube seen by two C-arm views 60 degrees apart, 256 px.
Scene scene() {
  gimm::CArm ca, cb;
  ca.primary_deg = 30;
  cb.primary_deg = -30;
  cb.secondary_deg = 20;
  for (gimm::CArm* c : {&ca, &cb}) c->rows = c->cols = 256;
  Scene s{ca.camera(), cb.camera(), gimm::Points2<double>(2, 60), gimm::Points2<double>(2, 60), {}};
  for (int k = 0; k < 60; ++k) {
    const Eigen::Vector3d X(std::sin(1.3 * k) * 20, std::cos(0.7 * k) * 20,
                            std::sin(0.37 * k) * 20);
    s.world.push_back(X);
    s.xa.col(k) = s.a.project(X).uv;
    s.xb.col(k) = s.b.project(X).uv;
  }
  return s;
}

/// F up to scale and sign, as a unit vector with a positive largest entry.
template <class M>
Eigen::Matrix3d normalised(const M& F) {
  Eigen::Matrix3d d = F.template cast<double>();
  d /= d.norm();
  Eigen::Index r, c;
  d.cwiseAbs().maxCoeff(&r, &c);
  return d(r, c) < 0 ? Eigen::Matrix3d(-d) : d;
}

}  // namespace

TEST_CASE("Geometry in float: F, the 8-point and gating agree with double", "[geometry][float]") {
  const Scene s = scene();
  const gimm::Cameraf af = s.a.cast<float>(), bf = s.b.cast<float>();
  const Eigen::Matrix3d F = gimm::fundamental_from_cameras(s.a, s.b);
  const Eigen::Matrix3f Ff = gimm::fundamental_from_cameras(af, bf);
  CHECK((normalised(Ff) - normalised(F)).norm() < 1e-4);

  const gimm::Points2<float> xa = s.xa.cast<float>(), xb = s.xb.cast<float>();
  const gimm::VectorX<float> ones = gimm::VectorX<float>::Ones(60);
  const auto F8 = gimm::fundamental_8pt<float>(xa, xb, ones);
  REQUIRE(F8);
  for (int k = 0; k < 60; ++k)  // every true pair on its epipolar line (float: 0.05 px)
    CHECK(gimm::symmetric_epipolar_distance_sq<float>(*F8, xa.col(k), xb.col(k)) < 0.05f * 0.05f);

  gimm::GateOptions go;
  go.delta_px = 1.0;
  const gimm::GateResult<float> g = gimm::gate_with_fundamental<float>(Ff, xa, xb, ones, go);
  CHECK(std::count(g.keep.begin(), g.keep.end(), 1) == 60);
  const gimm::GateResult<float> ref = gimm::gate_reference<float>(xa, xb, ones, go);
  REQUIRE(ref.F);
  CHECK((normalised(*ref.F) - normalised(F)).norm() < 1e-3);
}

TEST_CASE("Geometry in float: the midpoint, reprojection and the pair's isocenter agree",
          "[geometry][float]") {
  const Scene s = scene();
  const gimm::Cameraf af = s.a.cast<float>(), bf = s.b.cast<float>();
  const Eigen::Vector3f iso = gimm::pair_isocenter(af, bf);
  CHECK((iso.cast<double>() - gimm::pair_isocenter(s.a, s.b)).norm() < 1e-3);
  for (int k = 0; k < 60; k += 7) {
    const std::vector<Eigen::Vector2f> px = {s.xa.col(k).cast<float>(), s.xb.col(k).cast<float>()};
    const auto mid = gimm::triangulate_midpoint<float>({af, bf}, px);
    REQUIRE(mid);
    CHECK((mid->cast<double>() - s.world[k]).norm() < 0.05);
    CHECK(gimm::reprojection_error<float>(af, *mid, px[0]) < 0.05f);
  }
}
