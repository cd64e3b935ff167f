#pragma once
/// Calibration error of a C-arm view, for the stability sweeps: the camera a matcher is given
/// is moved while the image stays as rendered (docs/stability.md, "Calibration error").
///
/// The C-arm rotates about `pivot` (the isocentre) by `deg` about each of the two axes across
/// the viewing direction (the camera's x and y axes: errors in the primary and the secondary
/// angle), each with a random sign, and the table shifts by `mm` in a random direction. The
/// detector stays on the C-arm: K, rows and cols do not change.
#include <Eigen/Geometry>
#include <cmath>

#include "gimm/core/constants.hpp"
#include "gimm/core/error.hpp"
#include "gimm/core/rng.hpp"
#include "gimm/geometry/camera.hpp"

namespace gimm {

struct CameraError {
  double deg = 0;  ///< rotation error about each axis across the view, degrees
  double mm = 0;   ///< table / isocentre shift, mm
  bool none() const { return deg == 0 && mm == 0; }
  void validate() const {
    GIMM_CHECK(std::isfinite(deg) && deg >= 0 && deg <= 45,
               "CameraError::deg must be in [0, 45] degrees, got " << deg);
    GIMM_CHECK(std::isfinite(mm) && mm >= 0 && mm <= 1000,
               "CameraError::mm must be in [0, 1000] mm, got " << mm);
  }
};

/// The camera moved rigidly: its centre C -> pivot + Q (C - pivot) + shift, orientation R Q^T.
inline Camerad moved_camera(const Camerad& c, const Eigen::Vector3d& pivot,
                            const Eigen::Matrix3d& Q, const Eigen::Vector3d& shift) {
  const Eigen::Matrix3d R = c.R() * Q.transpose();
  const Eigen::Vector3d centre = pivot + Q * (c.center() - pivot) + shift;
  return Camerad(c.model(), c.K(), R, -R * centre, c.rows(), c.cols());
}

inline Camerad perturbed_camera(const Camerad& c, const Eigen::Vector3d& pivot,
                                const CameraError& e, Rng& rng) {
  GIMM_CHECK(std::isfinite(e.deg) && e.deg >= 0 && e.deg <= 45,
             "camera error: rotation must be in [0, 45] degrees, got " << e.deg);
  GIMM_CHECK(std::isfinite(e.mm) && e.mm >= 0 && e.mm <= 1000,
             "camera error: shift must be in [0, 1000] mm, got " << e.mm);
  const auto sign = [&] { return rng.uniform() < 0.5 ? -1.0 : 1.0; };
  const Eigen::Vector3d x_axis = c.R().row(0).transpose(), y_axis = c.R().row(1).transpose();
  const Eigen::Matrix3d Q = (Eigen::AngleAxisd(sign() * deg_to_rad(e.deg), x_axis) *
                             Eigen::AngleAxisd(sign() * deg_to_rad(e.deg), y_axis))
                                .toRotationMatrix();
  Eigen::Vector3d direction(rng.normal(), rng.normal(), rng.normal());
  direction /= direction.norm();
  return moved_camera(c, pivot, Q, e.mm * direction);
}

}  // namespace gimm
