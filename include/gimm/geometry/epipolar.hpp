#pragma once
/// Epipolar geometry between two views.
///
/// Convention: x_b^T F x_a = 0 for homogeneous pixel coordinates x_a in image A and x_b in
/// image B (F maps points of A to epipolar lines in B). Distances are in pixels; functions
/// named ..._sq return squared pixels. F is defined up to scale; functions returning F
/// normalise it to unit Frobenius norm with its largest-magnitude entry positive.
#include <Eigen/Core>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <cmath>
#include <limits>

#include "gimm/core/error.hpp"
#include "gimm/geometry/camera.hpp"

namespace gimm {

template <class Scalar>
using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;

template <class Scalar>
Eigen::Matrix<Scalar, 3, 3> skew(const Eigen::Matrix<Scalar, 3, 1>& v) {
  Eigen::Matrix<Scalar, 3, 3> S;
  S << 0, -v.z(), v.y(),  //
      v.z(), 0, -v.x(),   //
      -v.y(), v.x(), 0;
  return S;
}

/// Scales F to unit Frobenius norm with its largest-magnitude entry positive (a canonical
/// representative, so equal F compare equal). Throws on a zero or non-finite F.
template <class Derived>
Matrix3<typename Derived::Scalar> normalize_fundamental(const Eigen::MatrixBase<Derived>& F) {
  using Scalar = typename Derived::Scalar;
  const Scalar norm = F.norm();
  GIMM_CHECK(F.allFinite() && norm > 0, "normalize_fundamental: F is zero or not finite");
  Eigen::Index r = 0, c = 0;
  F.cwiseAbs().maxCoeff(&r, &c);
  return (F(r, c) < 0 ? Scalar(-1) : Scalar(1)) * F / norm;
}

/// F from two cameras (Hartley & Zisserman, eq. 9.1): F = [e_b]_x P_b P_a^+, with
/// e_b = P_b C_a the epipole in B and C_a the homogeneous centre of A (a point at infinity for an
/// orthographic camera, which makes F affine: its top-left 2x2 block is zero when both
/// cameras are orthographic).
/// Evaluated on the calibrated cameras K^-1 P (entries near 1 and the source distance, instead
/// of the focal length squared) with P_a^+ from a QR factorisation, then mapped back:
/// F = K_b^-T F' K_a^-1. Forming P_a P_a^T directly squares a condition number of ~1e6 and
/// leaves epipolar residuals of 1e-6 px; this way they are ~1e-13 px.
/// Throws if the two centres coincide (no baseline: F is undefined).
template <class Scalar>
Matrix3<Scalar> fundamental_from_cameras(const Camera<Scalar>& a, const Camera<Scalar>& b) {
  using Mat34 = Eigen::Matrix<Scalar, 3, 4>;
  const Mat34 Pa = a.K().inverse() * a.P();
  const Mat34 Pb = b.K().inverse() * b.P();
  const Eigen::Matrix<Scalar, 3, 1> e_b = Pb * a.center_homogeneous();
  // P_a^T = Q R  =>  P_a^+ = P_a^T (P_a P_a^T)^-1 = Q R^-T.
  const Eigen::HouseholderQR<Eigen::Matrix<Scalar, 4, 3>> qr(Pa.transpose());
  const Eigen::Matrix<Scalar, 4, 3> Q = qr.householderQ() * Eigen::Matrix<Scalar, 4, 3>::Identity();
  const Matrix3<Scalar> R_upper =
      qr.matrixQR().template topRows<3>().template triangularView<Eigen::Upper>();
  const Eigen::Matrix<Scalar, 4, 3> Pa_pinv = Q * R_upper.transpose().inverse();
  const Matrix3<Scalar> F_calibrated = skew(e_b) * Pb * Pa_pinv;
  GIMM_CHECK(
      F_calibrated.allFinite() && F_calibrated.norm() > Scalar(1e-9) * Pb.norm() * Pa_pinv.norm(),
      "fundamental_from_cameras: the two cameras share their centre (or viewing "
      "direction, if orthographic); F is undefined");
  return normalize_fundamental(b.K().inverse().transpose() * F_calibrated * a.K().inverse());
}

/// Epipolar line in B of x_a: l_b = F x_a (a, b, c with a u + b v + c = 0).
template <class Scalar>
Eigen::Matrix<Scalar, 3, 1> epipolar_line_b(const Matrix3<Scalar>& F,
                                            const Eigen::Matrix<Scalar, 2, 1>& x_a) {
  return F * x_a.homogeneous();
}

/// Epipolar line in A of x_b: l_a = F^T x_b.
template <class Scalar>
Eigen::Matrix<Scalar, 3, 1> epipolar_line_a(const Matrix3<Scalar>& F,
                                            const Eigen::Matrix<Scalar, 2, 1>& x_b) {
  return F.transpose() * x_b.homogeneous();
}

/// Pixel distance of point x from the line l = (a, b, c). Infinity if l has no direction.
template <class Scalar>
Scalar point_line_distance(const Eigen::Matrix<Scalar, 3, 1>& l,
                           const Eigen::Matrix<Scalar, 2, 1>& x) {
  const Scalar n = std::hypot(l.x(), l.y());
  if (!(n > 0)) return std::numeric_limits<Scalar>::infinity();
  return std::abs(l.dot(x.homogeneous())) / n;
}

/// Squared symmetric epipolar distance, px^2 (the quantity the reference code gates on):
///   d2 = (x_b^T F x_a)^2 (1 / ((F x_a)_1^2 + (F x_a)_2^2) + 1 / ((F^T x_b)_1^2 + (F^T x_b)_2^2))
/// = squared distance of x_b to l_b plus squared distance of x_a to l_a.
template <class Scalar>
Scalar symmetric_epipolar_distance_sq(const Matrix3<Scalar>& F,
                                      const Eigen::Matrix<Scalar, 2, 1>& x_a,
                                      const Eigen::Matrix<Scalar, 2, 1>& x_b) {
  const Eigen::Matrix<Scalar, 3, 1> ha = x_a.homogeneous(), hb = x_b.homogeneous();
  const Eigen::Matrix<Scalar, 3, 1> lb = F * ha, la = F.transpose() * hb;
  const Scalar r = hb.dot(lb);
  const Scalar nb = lb.x() * lb.x() + lb.y() * lb.y();
  const Scalar na = la.x() * la.x() + la.y() * la.y();
  if (!(nb > 0) || !(na > 0)) return std::numeric_limits<Scalar>::infinity();
  return r * r * (Scalar(1) / nb + Scalar(1) / na);
}

/// Squared Sampson distance, px^2: (x_b^T F x_a)^2 / (|F x_a|_12^2 + |F^T x_b|_12^2), the
/// first-order approximation of the squared reprojection distance.
template <class Scalar>
Scalar sampson_distance_sq(const Matrix3<Scalar>& F, const Eigen::Matrix<Scalar, 2, 1>& x_a,
                           const Eigen::Matrix<Scalar, 2, 1>& x_b) {
  const Eigen::Matrix<Scalar, 3, 1> ha = x_a.homogeneous(), hb = x_b.homogeneous();
  const Eigen::Matrix<Scalar, 3, 1> lb = F * ha, la = F.transpose() * hb;
  const Scalar r = hb.dot(lb);
  const Scalar denom = lb.x() * lb.x() + lb.y() * lb.y() + la.x() * la.x() + la.y() * la.y();
  if (!(denom > 0)) return std::numeric_limits<Scalar>::infinity();
  return r * r / denom;
}

// The double instantiations above are the costly ones to compile (Eigen decompositions):
// gimm's own binaries compile them once (src/instances/) and see them as extern here.
// Consumers do not define GIMM_EXTERN_INSTANCES and instantiate them as usual.
#define GIMM_EPIPOLAR_INSTANCES(EXTERN)                                                   \
  EXTERN template Matrix3<double> fundamental_from_cameras<double>(const Camera<double>&, \
                                                                   const Camera<double>&);
#ifdef GIMM_EXTERN_INSTANCES
GIMM_EPIPOLAR_INSTANCES(extern)
#endif

}  // namespace gimm
