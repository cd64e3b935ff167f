// Consumer of the installed gimm package: two C-arm views, F, and a reprojection check.
#include <gimm/geometry.hpp>
#include <gimm/io/camera_json.hpp>
#include <gimm/version.hpp>
#include <iostream>

int main() {
  gimm::CArm lao;
  lao.primary_deg = 45;
  lao.secondary_deg = 20;
  gimm::CArm rao;
  rao.primary_deg = -30;
  const auto a = lao.camera();
  const auto b = rao.camera();
  const Eigen::Matrix3d F = gimm::fundamental_from_cameras(a, b);
  const Eigen::Vector3d X(10, -20, 30);
  // Distance in pixels from X's image in B to the epipolar line of its image in A.
  const Eigen::Vector3d line = gimm::epipolar_line_b(F, a.project(X).uv);
  const double residual = gimm::point_line_distance(line, b.project(X).uv);
  const auto round_trip = gimm::camera_from_json(gimm::to_json(a));
  std::cout << "gimm " << GIMM_VERSION_STRING << ": epipolar residual (px) = " << residual << "\n";
  return std::abs(residual) < 1e-6 && (round_trip.P() - a.P()).norm() < 1e-9 ? 0 : 1;
}
