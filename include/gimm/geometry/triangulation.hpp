#pragma once
/// Triangulation of one world point from its pixel coordinates in two or more views.
///
/// - triangulate_dlt: linear (DLT, Hartley & Zisserman 12.2), for perspective and orthographic
///   cameras alike: rows u P_3 - P_1 and v P_3 - P_2, each scaled to unit norm, smallest right
///   singular vector.
/// - triangulate_midpoint: the point closest (least squares) to all viewing rays; for two views,
///   the midpoint of the common perpendicular (two_rays.hpp: the same in closed form).
/// Invalid input (fewer than 2 views, counts that differ, non-finite pixels) throws gimm::Error.
/// Degenerate geometry (all rays parallel, or a solution at infinity) returns std::nullopt.
#include <Eigen/Core>
#include <Eigen/SVD>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/geometry/camera.hpp"
#include "gimm/geometry/two_rays.hpp"

namespace gimm {

namespace detail {
template <class Scalar>
void check_views(const char* who, const std::vector<Camera<Scalar>>& cameras,
                 const std::vector<Eigen::Matrix<Scalar, 2, 1>>& pixels) {
  GIMM_CHECK(cameras.size() == pixels.size(),
             who << ": " << cameras.size() << " cameras but " << pixels.size() << " pixels");
  GIMM_CHECK(cameras.size() >= 2, who << ": need at least 2 views, got " << cameras.size());
  for (std::size_t v = 0; v < pixels.size(); ++v)
    GIMM_CHECK(pixels[v].allFinite(), who << ": pixel of view " << v << " is not finite ("
                                          << pixels[v].transpose() << ")");
}
}  // namespace detail

template <class Scalar>
std::optional<Eigen::Matrix<Scalar, 3, 1>> triangulate_dlt(
    const std::vector<Camera<Scalar>>& cameras,
    const std::vector<Eigen::Matrix<Scalar, 2, 1>>& pixels) {
  detail::check_views("triangulate_dlt", cameras, pixels);
  const Eigen::Index n = static_cast<Eigen::Index>(cameras.size());
  Eigen::Matrix<Scalar, Eigen::Dynamic, 4> A(2 * n, 4);
  for (Eigen::Index v = 0; v < n; ++v) {
    const Eigen::Matrix<Scalar, 3, 4> P = cameras[static_cast<std::size_t>(v)].P();
    const auto& x = pixels[static_cast<std::size_t>(v)];
    A.row(2 * v) = x.x() * P.row(2) - P.row(0);
    A.row(2 * v + 1) = x.y() * P.row(2) - P.row(1);
  }
  for (Eigen::Index r = 0; r < A.rows(); ++r) A.row(r).normalize();
  Eigen::JacobiSVD<Eigen::Matrix<Scalar, Eigen::Dynamic, 4>> svd(A, Eigen::ComputeFullV);
  const auto& sigma = svd.singularValues();
  if (!(sigma(2) > Scalar(1e3) * std::numeric_limits<Scalar>::epsilon() * sigma(0)))
    return std::nullopt;  // one-parameter family of solutions: rays are parallel
  const Eigen::Matrix<Scalar, 4, 1> X = svd.matrixV().col(3);
  if (!(std::abs(X(3)) > std::numeric_limits<Scalar>::epsilon() * X.norm())) return std::nullopt;
  return X.template head<3>() / X(3);
}

template <class Scalar>
std::optional<Eigen::Matrix<Scalar, 3, 1>> triangulate_midpoint(
    const std::vector<Camera<Scalar>>& cameras,
    const std::vector<Eigen::Matrix<Scalar, 2, 1>>& pixels) {
  detail::check_views("triangulate_midpoint", cameras, pixels);
  using Mat3 = Eigen::Matrix<Scalar, 3, 3>;
  using Vec3 = Eigen::Matrix<Scalar, 3, 1>;
  Mat3 A = Mat3::Zero();
  Vec3 b = Vec3::Zero();
  for (std::size_t v = 0; v < cameras.size(); ++v) {
    const auto r = cameras[v].ray(pixels[v].x(), pixels[v].y());
    const Mat3 M = Mat3::Identity() - r.direction * r.direction.transpose();
    A += M;
    b += M * r.origin;
  }
  Eigen::JacobiSVD<Mat3> svd(A, Eigen::ComputeFullU | Eigen::ComputeFullV);
  // A copy, not a reference: GCC 12 at -O3 otherwise warns (-Wmaybe-uninitialized, a false
  // positive) in every translation unit that calls this with -Wall.
  const Vec3 sigma = svd.singularValues();
  if (!(sigma(2) > Scalar(1e3) * std::numeric_limits<Scalar>::epsilon() * sigma(0)))
    return std::nullopt;
  return svd.solve(b);
}

/// Reprojection error in px of world point X against the observed pixel; infinity when X is
/// at or behind a perspective source.
template <class Scalar>
Scalar reprojection_error(const Camera<Scalar>& camera, const Eigen::Matrix<Scalar, 3, 1>& X,
                          const Eigen::Matrix<Scalar, 2, 1>& pixel) {
  const auto p = camera.project(X);
  if (!p.in_front) return std::numeric_limits<Scalar>::infinity();
  return (p.uv - pixel).norm();
}

// gimm's own binaries compile the double instantiations once (src/instances/) and see them as
// extern here: the decompositions are costly to compile. The switch decides about this
// header's own bodies only; consumers do not define GIMM_EXTERN_INSTANCES and instantiate them
// as usual.
// The DLT (a dynamic-size SVD) takes as long to compile as the rest: a file of its own each.
#define GIMM_TRIANGULATION_DLT_INSTANCES(EXTERN)                                      \
  EXTERN template std::optional<Eigen::Matrix<double, 3, 1>> triangulate_dlt<double>( \
      const std::vector<Camera<double>>&, const std::vector<Eigen::Matrix<double, 2, 1>>&);
#define GIMM_TRIANGULATION_INSTANCES(EXTERN)                                                \
  EXTERN template std::optional<Eigen::Matrix<double, 3, 1>> triangulate_midpoint<double>(  \
      const std::vector<Camera<double>>&, const std::vector<Eigen::Matrix<double, 2, 1>>&); \
  EXTERN template double reprojection_error<double>(const Camera<double>&,                  \
                                                    const Eigen::Matrix<double, 3, 1>&,     \
                                                    const Eigen::Matrix<double, 2, 1>&);

#ifdef GIMM_EXTERN_INSTANCES
GIMM_TRIANGULATION_DLT_INSTANCES(extern)
GIMM_TRIANGULATION_INSTANCES(extern)
#endif

}  // namespace gimm
