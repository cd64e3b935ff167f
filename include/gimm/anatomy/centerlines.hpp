#pragma once
/// Coronary centerline trees: ordered polylines in world mm (patient LPS) with a lumen radius
/// per point, a branch name, a parent and the system (LCA or RCA) each belongs to. The
/// phantom produces them analytically (ground truth); anatomy/skeleton.hpp extracts them from
/// a mask. Every later stage (labels, metrics) works on this one representation.
#include <Eigen/Core>
#include <algorithm>
#include <string>
#include <utility>
#include <vector>

#include "gimm/anatomy/coronary_system.hpp"
#include "gimm/core/error.hpp"

namespace gimm {

namespace detail {

/// Distance from p to the segment [a, b] and the parameter (0..1) of the closest point.
inline double segment_distance(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                               const Eigen::Vector3d& b, double* t_out = nullptr) {
  const Eigen::Vector3d ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  if (t_out) *t_out = t;
  return (p - (a + t * ab)).norm();
}

}  // namespace detail

struct CenterlineBranch {
  std::string name;  ///< e.g. "LAD", "D1", "RCA", "PDA"
  CoronarySystem system = CoronarySystem::LCA;
  int parent = -1;                      ///< index of the parent branch in the tree, -1 for a root
  std::vector<Eigen::Vector3d> points;  ///< world mm, ordered from proximal to distal
  std::vector<double> radii;            ///< lumen radius (mm) at each point

  double length() const {
    double sum = 0;
    for (std::size_t n = 1; n < points.size(); ++n) sum += (points[n] - points[n - 1]).norm();
    return sum;
  }
};

struct CenterlineTree {
  std::vector<CenterlineBranch> branches;

  /// Throws if a branch is empty, has radii of another length, non-finite or non-positive
  /// values, or a parent index out of range. `what` names the source in the message.
  void validate(const std::string& what) const {
    for (std::size_t b = 0; b < branches.size(); ++b) {
      const auto& br = branches[b];
      GIMM_CHECK(br.points.size() >= 2,
                 what << ": branch '" << br.name << "' has " << br.points.size() << " points");
      GIMM_CHECK(br.radii.size() == br.points.size(), what << ": branch '" << br.name << "' has "
                                                           << br.points.size() << " points but "
                                                           << br.radii.size() << " radii");
      GIMM_CHECK(br.parent >= -1 && br.parent < static_cast<int>(branches.size()) &&
                     br.parent != static_cast<int>(b),
                 what << ": branch '" << br.name << "' has parent " << br.parent);
      for (std::size_t n = 0; n < br.points.size(); ++n)
        GIMM_CHECK(br.points[n].allFinite() && std::isfinite(br.radii[n]) && br.radii[n] > 0,
                   what << ": branch '" << br.name << "' point " << n << " is ("
                        << br.points[n].transpose() << ") with radius " << br.radii[n]);
    }
  }

  /// Appends the branches of `other` (another system's tree), their parent indices shifted to
  /// this tree's numbering.
  void append(const CenterlineTree& other) {
    const int shift = static_cast<int>(branches.size());
    for (auto b : other.branches) {
      if (b.parent >= 0) b.parent += shift;
      branches.push_back(std::move(b));
    }
  }

  /// Total centerline length (mm) of one system, or of all.
  double length(int system = -1) const {
    double sum = 0;
    for (const auto& br : branches)
      if (system < 0 || static_cast<int>(br.system) == system) sum += br.length();
    return sum;
  }
};

}  // namespace gimm
