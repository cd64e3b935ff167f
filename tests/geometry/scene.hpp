// Shared helpers of the geometry tests: seeded C-arm scenes with known correspondences.
#pragma once
#include <Eigen/Core>
#include <vector>

#include "gimm/core/rng.hpp"
#include "gimm/geometry/camera.hpp"
#include "gimm/geometry/carm.hpp"
#include "gimm/geometry/epipolar.hpp"

namespace gimm_test {

inline gimm::CArm carm_pose(double primary, double secondary,
                            gimm::ProjectionModel model = gimm::ProjectionModel::perspective) {
  gimm::CArm carm;
  carm.primary_deg = primary;
  carm.secondary_deg = secondary;
  carm.model = model;
  return carm;
}

/// N world points in a box of half-size `half` mm around the isocentre (a heart-sized cloud)
/// and their pixels in cameras a and b.
struct PairScene {
  std::vector<Eigen::Vector3d> world;
  Eigen::Matrix2Xd x_a, x_b;
};

inline PairScene make_pair_scene(const gimm::Camerad& a, const gimm::Camerad& b, int n,
                                 std::uint64_t seed, double half = 60) {
  gimm::Rng rng(seed);
  PairScene s;
  s.x_a.resize(2, n);
  s.x_b.resize(2, n);
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d X(rng.uniform(-half, half), rng.uniform(-half, half),
                            rng.uniform(-half, half));
    s.world.push_back(X);
    s.x_a.col(i) = a.project(X).uv;
    s.x_b.col(i) = b.project(X).uv;
  }
  return s;
}

/// max_i |x_b^T F x_a| / (|x_b| |F| |x_a|) over homogeneous pixel coordinates.
inline double max_relative_residual(const Eigen::Matrix3d& F, const Eigen::Matrix2Xd& x_a,
                                    const Eigen::Matrix2Xd& x_b) {
  double worst = 0;
  for (Eigen::Index i = 0; i < x_a.cols(); ++i) {
    const Eigen::Vector3d ha = x_a.col(i).homogeneous(), hb = x_b.col(i).homogeneous();
    worst = std::max(worst, std::abs(hb.dot(F * ha)) / (hb.norm() * F.norm() * ha.norm()));
  }
  return worst;
}

/// max_i of the squared symmetric epipolar distance, px^2.
inline double max_symmetric_sq(const Eigen::Matrix3d& F, const Eigen::Matrix2Xd& x_a,
                               const Eigen::Matrix2Xd& x_b) {
  double worst = 0;
  for (Eigen::Index i = 0; i < x_a.cols(); ++i)
    worst =
        std::max(worst, gimm::symmetric_epipolar_distance_sq<double>(F, x_a.col(i), x_b.col(i)));
  return worst;
}

}  // namespace gimm_test
