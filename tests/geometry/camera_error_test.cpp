// Calibration error (geometry/camera_error.hpp): a rotation about the isocentre keeps the
// isocentre on its pixel and tilts the principal axis by acos(cos^2 deg); the shift moves the
// source by exactly mm; zero error is the identity; bad sizes are refused.
#include <catch2/catch.hpp>
#include <cmath>

#include "gimm/geometry/camera_error.hpp"
#include "gimm/geometry/carm.hpp"

TEST_CASE("Camera error: rotation about the pivot, shift, identity", "[geometry][camera_error]") {
  gimm::CArm arm;
  arm.primary_deg = 30;
  arm.secondary_deg = 15;
  arm.isocenter = {5, -8, 12};
  const gimm::Camerad c = arm.camera();
  const Eigen::Vector3d pivot = arm.isocenter;
  for (std::uint64_t seed = 0; seed < 8; ++seed) {
    gimm::Rng rng(seed);
    const gimm::Camerad turned = gimm::perturbed_camera(c, pivot, {2.0, 0.0}, rng);
    CHECK((turned.project(pivot).uv - c.project(pivot).uv).norm() < 1e-9);
    const double tilt = std::acos(turned.principal_axis().dot(c.principal_axis()));
    const double d = gimm::deg_to_rad(2.0);
    CHECK(tilt == Approx(std::acos(std::cos(d) * std::cos(d))).epsilon(1e-9));
    CHECK((turned.center() - pivot).norm() == Approx((c.center() - pivot).norm()));
    gimm::Rng rng2(seed);
    const gimm::Camerad shifted = gimm::perturbed_camera(c, pivot, {0.0, 5.0}, rng2);
    CHECK((shifted.center() - c.center()).norm() == Approx(5.0));
    CHECK((shifted.R() - c.R()).cwiseAbs().maxCoeff() < 1e-12);
  }
  gimm::Rng rng(1);
  const gimm::Camerad same = gimm::perturbed_camera(c, pivot, {}, rng);
  CHECK((same.P() - c.P()).cwiseAbs().maxCoeff() < 1e-9);
  CHECK_THROWS_WITH(gimm::perturbed_camera(c, pivot, {-1.0, 0.0}, rng),
                    Catch::Contains("rotation") && Catch::Contains("-1"));
  CHECK_THROWS_WITH(gimm::perturbed_camera(c, pivot, {0.0, std::nan("")}, rng),
                    Catch::Contains("shift"));
}
