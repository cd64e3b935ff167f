#pragma once
/// Two rays in closed form (no decomposition): the midpoint of their common perpendicular, and
/// the isocenter of a C-arm pair (its principal axes' closest point). The geometric matcher
/// triangulates every candidate with the first and scales its thresholds at the second; cheap
/// to compile, they are apart from triangulation.hpp's DLT so that the matchers need not see it.
#include <Eigen/Core>
#include <optional>

#include "gimm/core/error.hpp"
#include "gimm/geometry/camera.hpp"

namespace gimm {

/// The midpoint of the common perpendicular of two rays (two views in closed form), nullopt
/// when they are parallel.
template <class Scalar>
std::optional<Eigen::Matrix<Scalar, 3, 1>> two_ray_midpoint(const Ray<Scalar>& r1,
                                                            const Ray<Scalar>& r2) {
  const Eigen::Matrix<Scalar, 3, 1> w0 = r1.origin - r2.origin;
  const Scalar b = r1.direction.dot(r2.direction), d = r1.direction.dot(w0),
               e = r2.direction.dot(w0);
  const Scalar denom = 1 - b * b;
  if (!(denom > Scalar(1e-12))) return std::nullopt;
  const Scalar s = (b * e - d) / denom, t = (e - b * d) / denom;
  return Scalar(0.5) * ((r1.origin + s * r1.direction) + (r2.origin + t * r2.direction));
}

/// The principal axes' closest point: the isocentre of a C-arm pair (for the magnification).
template <class Scalar>
Eigen::Matrix<Scalar, 3, 1> pair_isocenter(const Camera<Scalar>& a, const Camera<Scalar>& b) {
  const auto centre = [](const Camera<Scalar>& c) { return c.ray(c.K()(0, 2), c.K()(1, 2)); };
  const auto X = two_ray_midpoint(centre(a), centre(b));
  GIMM_CHECK(X, "pair_isocenter: the two views look along parallel axes (no isocentre)");
  return *X;
}

}  // namespace gimm
