#pragma once
/// Exact 3D-to-2D labels at no annotation cost.
///
/// Per view: every centerline point projected (2D pixel, depth along the principal axis, in
/// front of the source, on the detector, on the view's 2D vessel mask, overlap count there).
/// Per pair: dense correspondences (2D in A, 2D in B, 3D mm, branch, radius) for the points
/// valid in both views - in front, on the detector and on the projected vessel mask, as the
/// reference keeps them - plus `sparse_count` of them chosen by farthest-point sampling in 3D
/// from a seeded start (the reference's 20 sparse labels, matched by index across the pair),
/// and the exact F of the two cameras.
#include <Eigen/Core>
#include <optional>
#include <vector>

#include "gimm/anatomy/centerlines.hpp"
#include "gimm/core/error.hpp"
#include "gimm/core/image.hpp"
#include "gimm/core/rng.hpp"
#include "gimm/geometry/epipolar.hpp"

namespace gimm {

/// One centerline sample, flattened out of the tree.
struct LabelPoint {
  Eigen::Vector3d world;  ///< mm, LPS
  double radius = 0;      ///< lumen radius, mm
  int branch = -1;        ///< index into CenterlineTree::branches
  int index = -1;         ///< index of the point within its branch
};

/// All points of `system` (or of every system if empty), branch by branch, in tree order.
inline std::vector<LabelPoint> flatten_centerlines(const CenterlineTree& tree,
                                                   std::optional<CoronarySystem> system = {}) {
  std::vector<LabelPoint> out;
  for (std::size_t b = 0; b < tree.branches.size(); ++b) {
    const auto& br = tree.branches[b];
    if (system && br.system != *system) continue;
    for (std::size_t n = 0; n < br.points.size(); ++n)
      out.push_back({br.points[n], br.radii[n], static_cast<int>(b), static_cast<int>(n)});
  }
  return out;
}

struct ProjectedPoint {
  Eigen::Vector2d uv{0, 0};  ///< pixel coordinates (u = column, v = row; centres at integers)
  double depth = 0;          ///< mm along the principal axis from the source
  bool in_front = false;     ///< depth > 0
  bool in_image = false;     ///< on the detector
  bool on_mask = false;      ///< the nearest pixel is on the 2D vessel mask
  int overlap = 0;           ///< vessel passages at that pixel (0 if no overlap map)
  bool visible = true;       ///< no other vessel passage between the source and the point

  bool valid() const { return in_front && in_image && on_mask; }
};

/// Projects `points` into one view. `mask` (rows x cols, nonzero = vessel) and `overlap`
/// (passages per pixel) are optional; without a mask every in-image point counts as on it.
inline std::vector<ProjectedPoint> label_view(const std::vector<LabelPoint>& points,
                                              const Camerad& camera,
                                              const Image<std::uint8_t>* mask = nullptr,
                                              const Image<std::uint8_t>* overlap = nullptr) {
  for (const auto* img : {mask, overlap})
    GIMM_CHECK(!img || (img->rows() == camera.rows() && img->cols() == camera.cols()),
               "label_view: mask/overlap image is " << img->rows() << " x " << img->cols()
                                                    << " but the camera is " << camera.rows()
                                                    << " x " << camera.cols());
  std::vector<ProjectedPoint> out(points.size());
  for (std::size_t n = 0; n < points.size(); ++n) {
    const auto proj = camera.project(points[n].world);
    ProjectedPoint& p = out[n];
    p.uv = proj.uv;
    p.depth = proj.depth;
    p.in_front = proj.in_front;
    p.in_image = proj.in_front && camera.on_detector(proj.uv);
    if (!p.in_image) continue;
    const int col = static_cast<int>(std::lround(p.uv.x()));
    const int row = static_cast<int>(std::lround(p.uv.y()));
    const bool inside = row >= 0 && col >= 0 && row < camera.rows() && col < camera.cols();
    p.on_mask = inside && (!mask || (*mask)(row, col) != 0);
    p.overlap = inside && overlap ? (*overlap)(row, col) : 0;
  }
  return out;
}

/// Marks the in-image points of one view hidden behind another vessel: `unoccluded(world)` says
/// whether the ray from the source to a point meets no other vessel first (mesh mode:
/// VesselMeshProjector::unoccluded). Without such a test every point stays visible.
template <class Unoccluded>
void mark_occlusion(std::vector<ProjectedPoint>& view, const std::vector<LabelPoint>& points,
                    Unoccluded&& unoccluded) {
  GIMM_CHECK(view.size() == points.size(), "mark_occlusion: " << view.size()
                                                              << " projected points for "
                                                              << points.size() << " points");
  for (std::size_t n = 0; n < points.size(); ++n)
    if (view[n].in_image) view[n].visible = unoccluded(points[n].world);
}

/// Farthest-point sampling in 3D: starts at a seeded random point, then repeatedly takes the
/// point farthest from everything chosen (ties: the lowest index). Returns indices into
/// `points`, at most `count`, all distinct.
inline std::vector<std::size_t> farthest_point_sampling(const std::vector<Eigen::Vector3d>& points,
                                                        std::size_t count, Rng& rng) {
  std::vector<std::size_t> chosen;
  // A NaN distance compares false with every other: the sampling would return one point.
  for (std::size_t n = 0; n < points.size(); ++n)
    GIMM_CHECK(points[n].allFinite(), "farthest_point_sampling: point "
                                          << n << " is not finite: " << points[n].transpose());
  if (points.empty() || count == 0) return chosen;
  std::vector<double> nearest(points.size(), std::numeric_limits<double>::infinity());
  std::size_t next = static_cast<std::size_t>(rng.below(points.size()));
  while (chosen.size() < std::min(count, points.size())) {
    const std::size_t last = next;
    chosen.push_back(last);
    double best = -1;
    for (std::size_t n = 0; n < points.size(); ++n) {
      nearest[n] = std::min(nearest[n], (points[n] - points[last]).squaredNorm());
      if (nearest[n] > best) {
        best = nearest[n];
        next = n;
      }
    }
    if (best <= 0) break;  // every remaining point coincides with a chosen one
  }
  return chosen;
}

struct Correspondence {
  Eigen::Vector2d a;      ///< pixel in view A
  Eigen::Vector2d b;      ///< pixel in view B
  Eigen::Vector3d world;  ///< mm, LPS
  int branch = -1;
  int index = -1;  ///< point index within the branch
  double radius = 0;
};

struct PairLabels {
  std::vector<Correspondence> dense;
  std::vector<std::size_t> sparse;  ///< indices into `dense`, farthest-point sampled
  Eigen::Matrix3d F;                ///< exact, from the cameras: x_b^T F x_a = 0
};

/// Labels of one pair from the two views' projections of the same `points`.
inline PairLabels label_pair(const std::vector<LabelPoint>& points,
                             const std::vector<ProjectedPoint>& view_a,
                             const std::vector<ProjectedPoint>& view_b, const Camerad& camera_a,
                             const Camerad& camera_b, std::size_t sparse_count, Rng& rng) {
  GIMM_CHECK(view_a.size() == points.size() && view_b.size() == points.size(),
             "label_pair: " << points.size() << " points but " << view_a.size() << " and "
                            << view_b.size() << " projections");
  PairLabels out;
  out.F = fundamental_from_cameras(camera_a, camera_b);
  std::vector<Eigen::Vector3d> world;
  for (std::size_t n = 0; n < points.size(); ++n) {
    if (!view_a[n].valid() || !view_b[n].valid()) continue;
    out.dense.push_back({view_a[n].uv, view_b[n].uv, points[n].world, points[n].branch,
                         points[n].index, points[n].radius});
    world.push_back(points[n].world);
  }
  out.sparse = farthest_point_sampling(world, sparse_count, rng);
  return out;
}

}  // namespace gimm
