#pragma once
/// Camera: a projective (perspective, X-ray point source) or affine (orthographic, parallel
/// beam) camera mapping world millimetres to detector pixels with P = K [R | t].
///
/// Conventions (tested in tests/geometry/camera_test.cpp):
/// - R is orthonormal with det R = +1; camera axes are the rows of R: x_cam points along
///   increasing u (image right), y_cam points "up" in the image (decreasing v), z_cam points
///   from the source towards the detector. Since image rows grow downward while y_cam points
///   up, K has a negative second focal entry: K = [[f, 0, cu], [0, -f, cv], [0, 0, 1]].
/// - Pixel (col j, row i) has its centre at (u, v) = (j, i).
/// - Perspective: x ~ K (R X + t); the source (camera centre) is C = -R^T t; depth is the
///   distance along z_cam from the source plane, in mm.
/// - Orthographic: P = K [[1 0 0 0], [0 1 0 0], [0 0 0 1]] [[R t], [0 1]], so P's last row is
///   (0, 0, 0, 1) and f is 1 / (pixel size in mm). Every ray has direction z_cam; t places the
///   isocentre and z-component of t puts the virtual source plane at depth 0.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

#include "gimm/core/error.hpp"

namespace gimm {

enum class ProjectionModel { perspective, orthographic };

inline const char* to_string(ProjectionModel model) {
  return model == ProjectionModel::perspective ? "perspective" : "orthographic";
}

template <class Scalar>
struct Projection {
  Eigen::Matrix<Scalar, 2, 1> uv;  ///< pixel coordinates (u = col, v = row)
  Scalar depth;                    ///< mm along the principal axis, from the source (plane)
  bool in_front;                   ///< false when the point is at or behind the source
};

/// A ray: origin + s * direction, direction of unit length, s in mm.
template <class Scalar>
struct Ray {
  Eigen::Matrix<Scalar, 3, 1> origin;
  Eigen::Matrix<Scalar, 3, 1> direction;
};

template <class Scalar>
class Camera {
 public:
  using Vec2 = Eigen::Matrix<Scalar, 2, 1>;
  using Vec3 = Eigen::Matrix<Scalar, 3, 1>;
  using Mat3 = Eigen::Matrix<Scalar, 3, 3>;
  using Mat34 = Eigen::Matrix<Scalar, 3, 4>;

  Camera() = default;
  /// Checks: K upper triangular with K(2,2) = 1 and nonzero focal entries; R a rotation;
  /// rows, cols > 0; all entries finite.
  Camera(ProjectionModel model, const Mat3& K, const Mat3& R, const Vec3& t, int rows, int cols)
      : model_(model), K_(K), K_inverse_(K.inverse()), R_(R), t_(t), rows_(rows), cols_(cols) {
    GIMM_CHECK(rows > 0 && cols > 0,
               "Camera: image size must be positive, got " << rows << " x " << cols);
    GIMM_CHECK(K.allFinite() && R.allFinite() && t.allFinite(),
               "Camera: K, R and t must be finite");
    GIMM_CHECK(K(1, 0) == 0 && K(2, 0) == 0 && K(2, 1) == 0 && K(2, 2) == 1,
               "Camera: K must be upper triangular with K(2,2) = 1, got K =\n"
                   << K);
    GIMM_CHECK(K(0, 0) != 0 && K(1, 1) != 0, "Camera: K has a zero focal entry");
    // A focal entry (pixels per unit of depth-normalised length, or per mm orthographically)
    // far below any detector's makes K's inverse, and every back-projected ray, meaningless.
    GIMM_CHECK(std::abs(K(0, 0)) >= Scalar(1e-6) && std::abs(K(1, 1)) >= Scalar(1e-6),
               "Camera: K's focal entries must be at least 1e-6 in size, got " << K(0, 0) << " and "
                                                                               << K(1, 1));
    // A C-arm's K is in pixels and t in mm, both far below 1e9; beyond that the products that
    // follow (P, F, the centre) overflow or lose every digit.
    const Scalar largest = std::max(K.cwiseAbs().maxCoeff(), t.cwiseAbs().maxCoeff());
    GIMM_CHECK(largest <= Scalar(1e9), "Camera: K and t must lie within +-1e9 (pixels, mm), got "
                                           << largest << " in K =\n"
                                           << K << "\nt = " << t.transpose());
    const Scalar orthonormality = (R.transpose() * R - Mat3::Identity()).cwiseAbs().maxCoeff();
    GIMM_CHECK(orthonormality < Scalar(1e-5) && R.determinant() > 0,
               "Camera: R must be a rotation (|R^T R - I| = " << orthonormality << ", det = "
                                                              << R.determinant() << ")");
  }

  ProjectionModel model() const { return model_; }
  bool is_orthographic() const { return model_ == ProjectionModel::orthographic; }
  const Mat3& K() const { return K_; }
  const Mat3& R() const { return R_; }
  const Vec3& t() const { return t_; }
  int rows() const { return rows_; }
  int cols() const { return cols_; }

  /// The 3x4 projection matrix. Perspective: K [R | t]. Orthographic: last row (0, 0, 0, 1).
  Mat34 P() const {
    Mat34 Rt;
    Rt << R_, t_;
    if (!is_orthographic()) return K_ * Rt;
    Mat34 affine = Mat34::Zero();
    affine.template topRows<2>() = Rt.template topRows<2>();
    affine(2, 3) = 1;
    return K_ * affine;
  }

  /// Unit vector from the source towards the detector along the principal axis (z_cam).
  Vec3 principal_axis() const { return R_.row(2).transpose(); }

  /// Perspective: the source position in world mm. Orthographic: the point where the principal
  /// ray through the principal point meets the virtual source plane (depth 0).
  Vec3 center() const { return -R_.transpose() * t_; }

  /// Homogeneous camera centre: the right null vector of P. (C, 1) for perspective, the
  /// viewing direction (d, 0) for orthographic (a point at infinity).
  Eigen::Matrix<Scalar, 4, 1> center_homogeneous() const {
    Eigen::Matrix<Scalar, 4, 1> c;
    if (is_orthographic())
      c << principal_axis(), Scalar(0);
    else
      c << center(), Scalar(1);
    return c;
  }

  /// Projects a world point (mm). For a point at or behind the source (perspective) the
  /// returned uv is still the algebraic projection but in_front is false; callers must check.
  Projection<Scalar> project(const Vec3& X) const {
    const Vec3 Xc = R_ * X + t_;
    Projection<Scalar> out;
    out.depth = Xc.z();
    if (is_orthographic()) {
      out.uv = (K_.template topLeftCorner<2, 2>() * Xc.template head<2>() +
                K_.template topRightCorner<2, 1>());
      out.in_front = out.depth > 0;
      return out;
    }
    out.in_front = Xc.z() > 0;
    const Vec3 x = K_ * Xc;
    out.uv = x.template head<2>() / x.z();
    return out;
  }

  /// The ray through pixel coordinates (u, v): perspective rays start at the source,
  /// orthographic rays at the virtual source plane (depth 0). Direction has unit length and
  /// points from the source towards the detector.
  Ray<Scalar> ray(Scalar u, Scalar v) const {
    Ray<Scalar> r;
    if (is_orthographic()) {
      const Vec3 xy = K_inverse_ * Vec3(u, v, 1);  // camera-frame x, y in mm (z ignored)
      r.direction = principal_axis();
      r.origin = R_.transpose() * (Vec3(xy.x(), xy.y(), 0) - t_);
      return r;
    }
    r.origin = center();
    r.direction = (R_.transpose() * (K_inverse_ * Vec3(u, v, 1))).normalized();
    return r;
  }

  /// True when (u, v) lies on the detector, pixel centres at integers, so the detector spans
  /// [-0.5, cols - 0.5] x [-0.5, rows - 0.5].
  bool on_detector(const Vec2& uv) const {
    return uv.x() >= Scalar(-0.5) && uv.y() >= Scalar(-0.5) && uv.x() <= cols_ - Scalar(0.5) &&
           uv.y() <= rows_ - Scalar(0.5);
  }

  template <class Other>
  Camera<Other> cast() const {
    return Camera<Other>(model_, K_.template cast<Other>(), R_.template cast<Other>(),
                         t_.template cast<Other>(), rows_, cols_);
  }

 private:
  ProjectionModel model_ = ProjectionModel::perspective;
  Mat3 K_ = Mat3::Identity();
  Mat3 K_inverse_ = Mat3::Identity();  // kept: ray() is called per pixel and per candidate
  Mat3 R_ = Mat3::Identity();
  Vec3 t_ = Vec3::Zero();
  int rows_ = 1;
  int cols_ = 1;
};

using Camerad = Camera<double>;
using Cameraf = Camera<float>;

}  // namespace gimm
