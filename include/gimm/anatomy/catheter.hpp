#pragma once
/// The guiding catheter of a selective coronary injection, for phantoms: engaged a few mm in
/// the injected system's ostium, back through the aortic root, up the ascending aorta, over the
/// arch and down the descending aorta (the femoral approach), lying off the aorta's axis
/// towards its wall as a catheter does. Filled with undiluted contrast, it is the dark tube
/// every clinical frame shows running into the ostium; it is imaged, never labelled (docs/
/// realism.md). Sizes: a 6 F guiding catheter, 2.0 mm outer diameter, 1.8 mm lumen (the
/// contrast column, radius 0.9 mm, is what attenuates; the thin polymer wall is water-like).
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <vector>

#include "gimm/anatomy/centerlines.hpp"
#include "gimm/anatomy/phantom.hpp"
#include "gimm/anatomy/tube_mesh.hpp"
#include "gimm/core/error.hpp"
#include "gimm/core/rng.hpp"

namespace gimm {

struct CatheterOptions {
  double lumen_radius_mm = 0.9;  ///< the contrast column: a 6 F catheter's 1.8 mm lumen
  double engaged_mm = 4.0;       ///< how far the tip sits inside the coronary, mm
  /// Off the aorta's axis towards its wall, as a fraction of the aorta's radius, [0, 0.8].
  double wall_offset_min = 0.3, wall_offset_max = 0.6;
  double min_bend_mm = 15;  ///< the tightest bend beyond the ostium (a 6 F guide over the arch)
};

/// The catheter's centreline (a branch named "catheter", radius lumen_radius_mm) for the
/// `system` of a phantom with `anatomy` and `tree` (its analytic coronary tree); the offset
/// direction and size drawn from `rng`. Smoothed by tube_axes.
inline CenterlineBranch guiding_catheter(const PhantomAnatomy& anatomy, const CenterlineTree& tree,
                                         CoronarySystem system, Rng& rng,
                                         const CatheterOptions& o = {}) {
  GIMM_CHECK(
      anatomy.aorta_path.size() >= 2 && anatomy.aorta_radius_mm.size() == anatomy.aorta_path.size(),
      "guiding_catheter: the phantom's anatomy has no aorta path");
  GIMM_CHECK(
      o.wall_offset_min >= 0 && o.wall_offset_max <= 0.8 && o.wall_offset_min <= o.wall_offset_max,
      "guiding_catheter: the wall offset must lie in [0, 0.8], got [" << o.wall_offset_min << ", "
                                                                      << o.wall_offset_max << "]");
  GIMM_CHECK(std::isfinite(o.lumen_radius_mm) && o.lumen_radius_mm > 0 &&
                 std::isfinite(o.engaged_mm) && o.engaged_mm >= 0,
             "guiding_catheter: lumen radius must be > 0 and engagement >= 0 mm, got "
                 << o.lumen_radius_mm << " and " << o.engaged_mm);
  const CenterlineBranch* root = nullptr;
  for (const auto& b : tree.branches)
    if (b.system == system && b.parent < 0) {
      root = &b;
      break;
    }
  GIMM_CHECK(root, "guiding_catheter: the tree has no " << to_string(system) << " root branch");
  CenterlineBranch c;
  c.name = "catheter";
  c.system = system;
  // The engaged tip, back out to the ostium.
  std::vector<Eigen::Vector3d> points;
  double along = 0;
  std::size_t tip = 0;
  while (tip + 1 < root->points.size() && along < o.engaged_mm) {
    along += (root->points[tip + 1] - root->points[tip]).norm();
    ++tip;
  }
  for (std::size_t i = tip + 1; i-- > 0;) points.push_back(root->points[i]);
  // Then the aorta, off its axis by a fixed fraction of its radius in one direction carried
  // along the path (re-made perpendicular to the local axis at every point): control points
  // from the ostium (the aortic root itself is skipped: a catheter curves from the ostium into
  // the ascending aorta) every <= 30 mm, and a Catmull-Rom curve through them every 1 mm, so
  // the catheter bends as a stiff tube does, not at the path's corners.
  Eigen::Vector3d side(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
  if (side.norm() < 1e-6) side = Eigen::Vector3d::UnitX();
  const double offset = rng.uniform(o.wall_offset_min, o.wall_offset_max);
  const auto& path = anatomy.aorta_path;
  std::vector<Eigen::Vector3d> control{points.back()};
  for (std::size_t i = 1; i < path.size(); ++i) {
    const Eigen::Vector3d axis =
        (path[std::min(i + 1, path.size() - 1)] - path[i - 1]).normalized();
    Eigen::Vector3d d = side - side.dot(axis) * axis;
    if (d.norm() < 1e-6) d = detail::any_perpendicular(axis);
    side = d.normalized();
    const Eigen::Vector3d next = path[i] + offset * anatomy.aorta_radius_mm[i] * side;
    const int pieces =
        std::max(1, static_cast<int>(std::ceil((next - control.back()).norm() / 30)));
    const Eigen::Vector3d from = control.back();
    for (int k = 1; k <= pieces; ++k) control.push_back(from + (next - from) * k / pieces);
  }
  const std::size_t ostium = points.size() - 1;
  for (std::size_t s = 0; s + 1 < control.size(); ++s) {
    const Eigen::Vector3d& p0 = control[s == 0 ? 0 : s - 1];
    const Eigen::Vector3d& p1 = control[s];
    const Eigen::Vector3d& p2 = control[s + 1];
    const Eigen::Vector3d& p3 = control[std::min(s + 2, control.size() - 1)];
    const int steps = std::max(1, static_cast<int>(std::ceil((p2 - p1).norm())));
    for (int k = 1; k <= steps; ++k) {
      const double t = double(k) / steps, t2 = t * t, t3 = t2 * t;
      points.push_back(0.5 * (2 * p1 + (p2 - p0) * t + (2 * p0 - 5 * p1 + 4 * p2 - p3) * t2 +
                              (3 * p1 - p0 - 3 * p2 + p3) * t3));
    }
  }
  const Eigen::Vector3d ostium_point = points[ostium];
  c.points = std::move(points);
  c.radii.assign(c.points.size(), o.lumen_radius_mm);
  CenterlineTree one;
  one.branches.push_back(std::move(c));
  CenterlineBranch out = tube_axes(one).branches.front();
  // A stiff tube: beyond the ostium no bend under min_bend_mm (the spline still turns sharply
  // where the aorta's few path points do). Relaxed on the final 0.5 mm samples.
  std::size_t from = 0;
  for (std::size_t i = 1; i < out.points.size(); ++i)
    if ((out.points[i] - ostium_point).norm() < (out.points[from] - ostium_point).norm()) from = i;
  std::vector<Eigen::Vector3d> body(out.points.begin() + static_cast<std::ptrdiff_t>(from),
                                    out.points.end());
  detail::relax_bends(body, std::vector<double>(body.size(), o.lumen_radius_mm), o.min_bend_mm,
                      50000);
  std::copy(body.begin(), body.end(), out.points.begin() + static_cast<std::ptrdiff_t>(from));
  return out;
}

}  // namespace gimm
