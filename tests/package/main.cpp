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
  const double residual = b.project(X).uv.homogeneous().dot(F * a.project(X).uv.homogeneous());
  const auto round_trip = gimm::camera_from_json(gimm::to_json(a));
  std::cout << "gimm " << GIMM_VERSION_STRING << ": x_b^T F x_a = " << residual << "\n";
  return std::abs(residual) < 1e-9 && (round_trip.P() - a.P()).norm() < 1e-9 ? 0 : 1;
}
