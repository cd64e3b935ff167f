#pragma once
/// 3D from a matched pair: each match triangulated with both cameras (DLT), kept when it
/// reprojects within `max_reprojection_px` in both views; and the points as VTK polydata.
///
/// With the exact F of calibrated cameras a true match lies on its epipolar line, and its
/// reprojection error is about half its distance from the line; a match off the line by more
/// than twice the limit cannot pass.
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <optional>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/geometry/camera.hpp"
#include "gimm/geometry/triangulation.hpp"
#include "gimm/match/matches.hpp"

namespace gimm {

struct ReconstructedPoint {
  Eigen::Vector2d a, b;                           ///< pixels in A and B
  Eigen::Vector3d world;                          ///< patient mm
  double reprojection_a = 0, reprojection_b = 0;  ///< px
  double confidence = 0;
};

struct Reconstruction {
  std::vector<ReconstructedPoint> points;
  std::size_t dropped_degenerate = 0;    ///< parallel rays or a point behind a source
  std::size_t dropped_reprojection = 0;  ///< reprojected further than the limit
};

inline Reconstruction reconstruct_matches(const PairMatches& matches, const Camerad& camera_a,
                                          const Camerad& camera_b, double max_reprojection_px) {
  GIMM_CHECK(std::isfinite(max_reprojection_px) && max_reprojection_px > 0,
             "reconstruction: the reprojection limit must be > 0 px, got " << max_reprojection_px);
  Reconstruction out;
  const std::vector<Camerad> cameras{camera_a, camera_b};
  for (std::size_t k = 0; k < matches.size(); ++k) {
    const auto X = triangulate_dlt(cameras, {matches.points_a[k], matches.points_b[k]});
    if (!X) {
      ++out.dropped_degenerate;
      continue;
    }
    ReconstructedPoint p{matches.points_a[k],
                         matches.points_b[k],
                         *X,
                         reprojection_error(camera_a, *X, matches.points_a[k]),
                         reprojection_error(camera_b, *X, matches.points_b[k]),
                         matches.confidence[k]};
    if (!std::isfinite(p.reprojection_a) || !std::isfinite(p.reprojection_b)) {
      ++out.dropped_degenerate;
      continue;
    }
    if (std::max(p.reprojection_a, p.reprojection_b) > max_reprojection_px) {
      ++out.dropped_reprojection;
      continue;
    }
    out.points.push_back(p);
  }
  return out;
}

/// Legacy VTK polydata (ASCII) of points in mm, with line segments between point indices.
inline std::string vtk_polydata(const std::string& title,
                                const std::vector<Eigen::Vector3d>& points,
                                const std::vector<std::pair<std::size_t, std::size_t>>& lines) {
  std::ostringstream vtk;
  vtk.precision(9);
  vtk << "# vtk DataFile Version 3.0\n"
      << title << "\nASCII\nDATASET POLYDATA\nPOINTS " << points.size() << " double\n";
  for (const auto& p : points) vtk << p.x() << ' ' << p.y() << ' ' << p.z() << '\n';
  vtk << "LINES " << lines.size() << ' ' << 3 * lines.size() << '\n';
  for (const auto& [i, j] : lines) vtk << "2 " << i << ' ' << j << '\n';
  return vtk.str();
}

}  // namespace gimm
