#pragma once
/// The 3D error of a reconstruction: each triangulated point's distance to the nearest point
/// of the true centerlines (the polylines, not only their vertices), in mm.
#include <Eigen/Core>
#include <algorithm>
#include <limits>
#include <vector>

#include "gimm/anatomy/centerlines.hpp"

namespace gimm {

/// Distance from p to the segment [a, b].
inline double distance_to_segment(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                  const Eigen::Vector3d& b) {
  const Eigen::Vector3d d = b - a;
  const double len2 = d.squaredNorm();
  const double t = len2 > 0 ? std::clamp((p - a).dot(d) / len2, 0.0, 1.0) : 0.0;
  return (a + t * d - p).norm();
}

/// Distance from p to the nearest centerline of `tree`; infinity for an empty tree.
inline double distance_to_centerlines(const Eigen::Vector3d& p, const CenterlineTree& tree) {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& branch : tree.branches) {
    if (branch.points.size() == 1) best = std::min(best, (branch.points[0] - p).norm());
    for (std::size_t n = 1; n < branch.points.size(); ++n)
      best = std::min(best, distance_to_segment(p, branch.points[n - 1], branch.points[n]));
  }
  return best;
}

}  // namespace gimm
