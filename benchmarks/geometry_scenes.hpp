#pragma once
// Synthetic two-view scenes shared by the geometry benchmarks (geometry_bench.cpp) and the
// accuracy/stability tables (geometry_accuracy_bench.cpp), so both measure the same point sets.
//
// A scene: two C-arm views (gimm::CArm, SID 1000, SOD 750, 512 x 512 detector of 0.5 mm pixels),
// N random 3D points in a heart-sized region around the isocentre (a 120 mm cube, or a thin
// slab for the near-planar sweep) that project onto both detectors, their noise-free pixel
// correspondences, and the observed ones (Gaussian pixel noise on every coordinate, and a fixed
// share of outliers whose image-B point is replaced by a uniform random detector pixel).
// Deterministic: everything is drawn from gimm::Rng(seed).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <vector>

#include "gimm/core/rng.hpp"
#include "gimm/geometry/carm.hpp"
#include "gimm/geometry/epipolar.hpp"
#include "gimm/geometry/fundamental.hpp"

#ifdef GIMM_HAVE_OPENCV
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#endif

namespace gimm_bench {

struct SceneOptions {
  int n = 256;                    ///< correspondences
  double noise_px = 0.0;          ///< sigma of the Gaussian noise on each pixel coordinate
  double outlier_fraction = 0.0;  ///< round(fraction N) correspondences get a random B point
  double region_mm = 120.0;       ///< edge of the cube (or slab) of 3D points
  /// < 0: points fill the cube. >= 0: points lie in a region_mm x region_mm slab of this
  /// thickness (mm) through the isocentre, with a random orientation (near-planar scenes).
  double slab_mm = -1.0;
  /// < 0: a routine pair (both views random within routine coronary angles, 30-100 degrees
  /// apart). >= 0: view B is view A rotated about the patient axis by this angle between the
  /// two source directions (degrees).
  double separation_deg = -1.0;
  gimm::ProjectionModel model = gimm::ProjectionModel::perspective;
  std::uint64_t seed = 1;
  int held_out = 1000;  ///< extra noise-free correspondences in the full cube, for evaluation
};

struct Scene {
  gimm::CArm arm_a, arm_b;
  gimm::Camerad cam_a, cam_b;
  Eigen::Matrix3d F_true;
  gimm::Points2<double> true_a, true_b;  ///< noise-free correspondences (2, N)
  gimm::Points2<double> obs_a, obs_b;    ///< observed: noise and outliers (2, N)
  std::vector<char> outlier;             ///< (N) 1 where obs_b is a random pixel
  gimm::Points2<double> held_a, held_b;  ///< noise-free, fresh points in the full cube
  double separation_deg = 0;             ///< angle between the two source directions
};

inline double separation_deg(const gimm::CArm& a, const gimm::CArm& b) {
  const double c = a.source_direction().dot(b.source_direction());
  return gimm::rad_to_deg(std::acos(std::clamp(c, -1.0, 1.0)));
}

/// Random 3D point: in the cube, or in the slab spanned by (u, v) with normal w.
inline Eigen::Vector3d random_point(gimm::Rng& rng, const SceneOptions& o,
                                    const Eigen::Matrix3d& slab_axes) {
  const double h = o.region_mm / 2;
  if (o.slab_mm < 0) return {rng.uniform(-h, h), rng.uniform(-h, h), rng.uniform(-h, h)};
  return slab_axes.col(0) * rng.uniform(-h, h) + slab_axes.col(1) * rng.uniform(-h, h) +
         slab_axes.col(2) * (o.slab_mm * (rng.uniform() - 0.5));
}

inline Scene make_scene(const SceneOptions& o) {
  gimm::Rng rng(o.seed);
  Scene s;
  s.arm_a.model = s.arm_b.model = o.model;
  s.arm_a.primary_deg = rng.uniform(-50, 50);  // routine coronary views: RAO/LAO, CRA/CAU
  s.arm_a.secondary_deg = rng.uniform(-30, 30);
  if (o.separation_deg < 0) {
    do {
      s.arm_b.primary_deg = rng.uniform(-60, 60);
      s.arm_b.secondary_deg = rng.uniform(-35, 35);
    } while (separation_deg(s.arm_a, s.arm_b) < 30 || separation_deg(s.arm_a, s.arm_b) > 100);
  } else {
    // Rotation about z by d moves the source direction (elevation b) through an angle theta
    // with cos theta = sin^2 b + cos^2 b cos d.
    const double b = gimm::deg_to_rad(s.arm_a.secondary_deg);
    const double cb2 = std::cos(b) * std::cos(b);
    const double cos_d =
        (std::cos(gimm::deg_to_rad(o.separation_deg)) - (1 - cb2)) / std::max(cb2, 1e-12);
    const double d = gimm::rad_to_deg(std::acos(std::clamp(cos_d, -1.0, 1.0)));
    s.arm_b.secondary_deg = s.arm_a.secondary_deg;
    s.arm_b.primary_deg = s.arm_a.primary_deg + (s.arm_a.primary_deg > 0 ? -d : d);
  }
  s.separation_deg = separation_deg(s.arm_a, s.arm_b);
  s.cam_a = s.arm_a.camera();
  s.cam_b = s.arm_b.camera();
  s.F_true = gimm::fundamental_from_cameras(s.cam_a, s.cam_b);

  // Slab orientation: a random rotation (from a random unit quaternion).
  Eigen::Quaterniond q(rng.normal(), rng.normal(), rng.normal(), rng.normal());
  const Eigen::Matrix3d slab_axes = q.normalized().toRotationMatrix();

  auto draw = [&](const SceneOptions& opts, int count, gimm::Points2<double>& a,
                  gimm::Points2<double>& b) {
    a.resize(2, count);
    b.resize(2, count);
    for (int i = 0; i < count;) {
      const Eigen::Vector3d X = random_point(rng, opts, slab_axes);
      const auto pa = s.cam_a.project(X), pb = s.cam_b.project(X);
      if (!pa.in_front || !pb.in_front || !s.cam_a.on_detector(pa.uv) ||
          !s.cam_b.on_detector(pb.uv))
        continue;
      a.col(i) = pa.uv;
      b.col(i) = pb.uv;
      ++i;
    }
  };
  draw(o, o.n, s.true_a, s.true_b);
  s.obs_a = s.true_a;
  s.obs_b = s.true_b;
  s.outlier.assign(static_cast<std::size_t>(o.n), 0);
  for (int i = 0; i < o.n; ++i)
    for (int k = 0; k < 2; ++k) {
      s.obs_a(k, i) += rng.normal(0.0, o.noise_px);
      s.obs_b(k, i) += rng.normal(0.0, o.noise_px);
    }
  // Exactly round(fraction N) outliers at random positions (partial Fisher-Yates).
  std::vector<int> order(static_cast<std::size_t>(o.n));
  for (int i = 0; i < o.n; ++i) order[static_cast<std::size_t>(i)] = i;
  const int outliers = static_cast<int>(std::lround(o.outlier_fraction * o.n));
  for (int k = 0; k < outliers; ++k) {
    const auto j = static_cast<std::size_t>(k) + rng.below(static_cast<std::uint64_t>(o.n - k));
    std::swap(order[static_cast<std::size_t>(k)], order[j]);
    const int i = order[static_cast<std::size_t>(k)];
    s.outlier[static_cast<std::size_t>(i)] = 1;
    s.obs_b(0, i) = rng.uniform(0, s.cam_b.cols() - 1);
    s.obs_b(1, i) = rng.uniform(0, s.cam_b.rows() - 1);
  }
  SceneOptions cube = o;
  cube.slab_mm = -1;
  draw(cube, o.held_out, s.held_a, s.held_b);
  return s;
}

/// Mean over correspondences of sqrt(symmetric_epipolar_distance_sq), in px: for each pair the
/// root of (distance of x_b to F x_a)^2 + (distance of x_a to F^T x_b)^2.
inline double mean_symmetric_epipolar_px(const Eigen::Matrix3d& F, const gimm::Points2<double>& a,
                                         const gimm::Points2<double>& b) {
  double sum = 0;
  for (Eigen::Index i = 0; i < a.cols(); ++i)
    sum += std::sqrt(gimm::symmetric_epipolar_distance_sq<double>(F, a.col(i), b.col(i)));
  return sum / static_cast<double>(a.cols());
}

/// How far the estimated epipolar line strays from the true one across image B: for each x_a,
/// the true line F_true x_a is clipped to B's detector and the larger distance of the two ends
/// of that segment from the line F x_a is taken (px); the mean over the points. Unlike the
/// distance of true correspondences (which only tests the lines where the points are), this is
/// what a correspondence search along the whole line sees.
inline double mean_line_deviation_px(const Eigen::Matrix3d& F, const Eigen::Matrix3d& F_true,
                                     const gimm::Points2<double>& a, const gimm::Camerad& cam_b) {
  const double u1 = cam_b.cols() - 0.5, v1 = cam_b.rows() - 0.5, lo = -0.5;
  double sum = 0;
  for (Eigen::Index i = 0; i < a.cols(); ++i) {
    const Eigen::Vector3d lt = F_true * a.col(i).homogeneous(), le = F * a.col(i).homogeneous();
    // Intersections of the true line with the four detector edges, kept if on the border.
    std::vector<Eigen::Vector2d> ends;
    for (const double u : {lo, u1})
      if (std::abs(lt.y()) > 0) {
        const double v = -(lt.x() * u + lt.z()) / lt.y();
        if (v >= lo && v <= v1) ends.emplace_back(u, v);
      }
    for (const double v : {lo, v1})
      if (std::abs(lt.x()) > 0) {
        const double u = -(lt.y() * v + lt.z()) / lt.x();
        if (u >= lo && u <= u1) ends.emplace_back(u, v);
      }
    double worst = 0;
    for (const auto& e : ends) worst = std::max(worst, gimm::point_line_distance<double>(le, e));
    sum += worst;
  }
  return sum / static_cast<double>(a.cols());
}

#ifdef GIMM_HAVE_OPENCV
inline std::vector<cv::Point2d> to_cv(const gimm::Points2<double>& x) {
  std::vector<cv::Point2d> out(static_cast<std::size_t>(x.cols()));
  for (Eigen::Index i = 0; i < x.cols(); ++i) out[static_cast<std::size_t>(i)] = {x(0, i), x(1, i)};
  return out;
}

/// cv::findFundamentalMat (x_a = points1, x_b = points2, so x_b^T F x_a = 0 as in gimm);
/// nullopt when OpenCV returns no matrix.
inline std::optional<Eigen::Matrix3d> opencv_fundamental(const std::vector<cv::Point2d>& a,
                                                         const std::vector<cv::Point2d>& b,
                                                         int method, double threshold_px = 3.0,
                                                         double confidence = 0.99,
                                                         int max_iters = 1000,
                                                         int* num_inliers = nullptr) {
  cv::Mat mask;
  const cv::Mat F = cv::findFundamentalMat(a, b, method, threshold_px, confidence, max_iters, mask);
  if (num_inliers) *num_inliers = mask.empty() ? 0 : cv::countNonZero(mask);
  if (F.rows != 3 || F.cols != 3) return std::nullopt;
  Eigen::Matrix3d out;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out(r, c) = F.at<double>(r, c);
  return out;
}
#endif

}  // namespace gimm_bench
