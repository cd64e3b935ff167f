#pragma once
/// Where epipolar lines meet 2D centerline chains: the geometric matcher's candidate search.
///
/// A line meets a chain at a crossing (between two consecutive points whose signed distances to
/// the line differ in sign: sub-point position, distance 0) or at a near miss (a point within the
/// tolerance, a local minimum of the distance, with no crossing beside it: tips, grazing vessels,
/// a line off by a few pixels). line_meetings() finds them all, in chain then point order.
///
/// The plain search looks at every point of every chain. ChainIndex skips, without changing the
/// result:
/// - chains, then blocks of 16 segments, whose bounding box lies beyond the tolerance on one side
///   of the line (the box's nearest and farthest corners from the signs of the line's normal);
/// - when every line passes through one point (the epipole: all epipolar lines of a view do), the
///   chains no line at that angle can reach: the pencil of lines through the epipole is a circle
///   of angles, and the lines meeting a chain's box, grown by the tolerance, form one arc of it
///   (a convex region seen from a point outside it spans less than a half-turn, its extreme lines
///   through corners). Arcs are kept in 1024 angle buckets, each bucket listing the chains whose
///   arc overlaps it.
/// Both are conservative (slack for rounding), so the fast search finds what the plain one finds;
/// the tests check that on random chains, with epipoles far, near, inside and at infinity.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include "gimm/core/constants.hpp"
#include "gimm/core/error.hpp"
#include "gimm/match/centerline_graph.hpp"

namespace gimm {
namespace detail {

/// The bounding box of a run of chain points.
struct PointBox {
  double lo_x = 0, lo_y = 0, hi_x = 0, hi_y = 0;
  /// Points first..last (inclusive).
  static PointBox of(const std::vector<Eigen::Vector2d>& p, std::size_t first, std::size_t last) {
    PointBox b{p[first].x(), p[first].y(), p[first].x(), p[first].y()};
    for (std::size_t j = first + 1; j <= last; ++j) {
      b.lo_x = std::min(b.lo_x, p[j].x()), b.hi_x = std::max(b.hi_x, p[j].x());
      b.lo_y = std::min(b.lo_y, p[j].y()), b.hi_y = std::max(b.hi_y, p[j].y());
    }
    return b;
  }
  /// Grows to hold `other` too.
  void cover(const PointBox& other) {
    lo_x = std::min(lo_x, other.lo_x), hi_x = std::max(hi_x, other.hi_x);
    lo_y = std::min(lo_y, other.lo_y), hi_y = std::max(hi_y, other.hi_y);
  }
  /// +1 (-1) when every point of the box lies more than `tol` on the positive (negative) side of
  /// the line l (unit normal), else 0. The 1e-6 px slack keeps the test conservative under
  /// rounding, so a run it rules out holds no crossing and no near miss.
  int side_beyond(const Eigen::Vector3d& l, double tol) const {
    const double x_min = l.x() * (l.x() > 0 ? lo_x : hi_x),
                 x_max = l.x() * (l.x() > 0 ? hi_x : lo_x);
    const double y_min = l.y() * (l.y() > 0 ? lo_y : hi_y),
                 y_max = l.y() * (l.y() > 0 ? hi_y : lo_y);
    const double margin = tol + 1e-6;
    if (x_min + y_min + l.z() > margin) return 1;
    if (x_max + y_max + l.z() < -margin) return -1;
    return 0;
  }
};

/// A chain's box, and the boxes of its blocks of kPoints segments: block q holds points
/// q kPoints .. min((q + 1) kPoints, m - 1), so consecutive blocks share a point and every
/// segment between two chain points lies inside one block.
struct ChainBlocks {
  static constexpr std::size_t kPoints = 16;
  PointBox box;
  std::vector<PointBox> blocks;
  explicit ChainBlocks(const std::vector<Eigen::Vector2d>& p)
      : box(PointBox::of(p, 0, p.size() - 1)) {
    for (std::size_t s = 0; s == 0 || s + 1 < p.size(); s += kPoints)
      blocks.push_back(PointBox::of(p, s, std::min(s + kPoints, p.size() - 1)));
  }
};

/// The point every line F x passes through (e^T F = 0: the left null vector of F, the epipole
/// of the view the lines are drawn in), homogeneous, unit length; nullopt when F has rank < 2.
/// The cross product of F's two most independent columns.
inline std::optional<Eigen::Vector3d> lines_common_point(const Eigen::Matrix3d& F) {
  Eigen::Vector3d best = Eigen::Vector3d::Zero();
  for (int i = 0; i < 3; ++i)
    for (int j = i + 1; j < 3; ++j) {
      const Eigen::Vector3d e = F.col(i).cross(F.col(j));
      if (e.norm() > best.norm()) best = e;
    }
  const double scale = F.norm() * F.norm();
  if (!(scale > 0) || !(best.norm() > 1e-12 * scale)) return std::nullopt;
  return best.normalized();
}

}  // namespace detail

/// Chains indexed for line_meetings(): each chain's blocks and, when every line searched passes
/// through one point, the chains each angle of that pencil of lines can reach within `tol`.
class ChainIndex {
 public:
  static constexpr int kBuckets = 1024;

  ChainIndex(const std::vector<Branch2d>& chains, double tol,
             const std::optional<Eigen::Vector3d>& pencil_point = std::nullopt)
      : tol_(tol) {
    GIMM_CHECK(std::isfinite(tol) && tol > 0,
               "ChainIndex: the tolerance must be finite and > 0, got " << tol);
    for (const Branch2d& chain : chains) {
      GIMM_CHECK(!chain.points.empty(), "ChainIndex: chain " << blocks_.size() << " has no points");
      for (const Eigen::Vector2d& p : chain.points)
        GIMM_CHECK(p.allFinite(), "ChainIndex: chain " << blocks_.size()
                                                       << " has a non-finite point (" << p.x()
                                                       << ", " << p.y() << ")");
      blocks_.emplace_back(chain.points);
      all_.push_back(static_cast<int>(all_.size()));
    }
    if (!blocks_.empty() && pencil_point && pencil_point->allFinite() && pencil_point->norm() > 0)
      build_pencil(pencil_point->normalized());
  }

  double tol() const { return tol_; }
  std::size_t size() const { return blocks_.size(); }
  const detail::ChainBlocks& blocks(std::size_t k) const { return blocks_[k]; }
  bool has_pencil() const { return !buckets_.empty(); }

  /// The chains (ascending) that the line l may meet within tol: those of l's angle bucket when
  /// the index has a pencil (l must pass through its point), else all.
  const std::vector<int>& chains_for(const Eigen::Vector3d& l) const {
    if (buckets_.empty() || !l.allFinite()) return all_;  // a non-finite line has no angle
    const Eigen::Vector3d ln = normalised_line(l);
    double phi = std::atan2(ln.dot(l1_), ln.dot(l0_));  // l and -l: one angle mod pi
    if (phi < 0) phi += kPi;
    const int b = std::clamp(static_cast<int>(phi / kPi * kBuckets), 0, kBuckets - 1);
    return buckets_[static_cast<std::size_t>(b)];
  }

 private:
  /// A line in the index's frame: pixels less the chains' centre, over their half-extent, so
  /// that the bucket angles resolve the chains' area alike for an epipole near or at infinity.
  Eigen::Vector3d normalised_line(const Eigen::Vector3d& l) const {
    return {scale_ * l.x(), scale_ * l.y(), l.x() * centre_.x() + l.y() * centre_.y() + l.z()};
  }

  void build_pencil(const Eigen::Vector3d& epipole) {
    detail::PointBox all = blocks_.front().box;
    for (const auto& b : blocks_) all.cover(b.box);
    centre_ = {0.5 * (all.lo_x + all.hi_x), 0.5 * (all.lo_y + all.hi_y)};
    scale_ = std::max(1.0, 0.5 * std::hypot(all.hi_x - all.lo_x, all.hi_y - all.lo_y));
    const Eigen::Vector3d e =
        Eigen::Vector3d(epipole.x() - centre_.x() * epipole.z(),
                        epipole.y() - centre_.y() * epipole.z(), scale_ * epipole.z())
            .normalized();
    // l0, l1: an orthonormal basis of the lines through e (l . e = 0).
    const Eigen::Vector3d helper =
        std::abs(e.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
    l0_ = e.cross(helper).normalized();
    l1_ = e.cross(l0_).normalized();
    // The angle, in (-pi, pi], of the line through e and the pixel point p.
    const auto angle_through = [&](double x, double y) {
      const Eigen::Vector3d p((x - centre_.x()) / scale_, (y - centre_.y()) / scale_, 1.0);
      const Eigen::Vector3d l = e.cross(p);
      return std::atan2(l.dot(l1_), l.dot(l0_));
    };
    buckets_.assign(kBuckets, {});
    const double grow = tol_ + 1e-6, slack = 1e-7;  // px, radians
    for (std::size_t k = 0; k < blocks_.size(); ++k) {
      const detail::PointBox& b = blocks_[k].box;
      std::array<double, 4> psi = {
          angle_through(b.lo_x - grow, b.lo_y - grow), angle_through(b.hi_x + grow, b.lo_y - grow),
          angle_through(b.lo_x - grow, b.hi_y + grow), angle_through(b.hi_x + grow, b.hi_y + grow)};
      std::sort(psi.begin(), psi.end());
      // The arc holding the four angles: the circle less its largest gap. A box seen from
      // outside spans less than a half-turn; from inside (or at its edge) the arc is a half-turn
      // or more, and every bucket gets the chain.
      double gap = psi[0] + 2 * kPi - psi[3], start = psi[0];
      for (std::size_t i = 1; i < 4; ++i)
        if (psi[i] - psi[i - 1] > gap) gap = psi[i] - psi[i - 1], start = psi[i];
      const int chain = static_cast<int>(k);
      const double width = 2 * kPi - gap;
      const long first = static_cast<long>(std::floor((start - slack) / kPi * kBuckets));
      const long last = static_cast<long>(std::floor((start + width + slack) / kPi * kBuckets));
      for (long i = first; i <= last && i < first + kBuckets; ++i)
        buckets_[static_cast<std::size_t>(((i % kBuckets) + kBuckets) % kBuckets)].push_back(chain);
    }
  }

  double tol_;
  std::vector<detail::ChainBlocks> blocks_;
  std::vector<int> all_;
  Eigen::Vector2d centre_ = Eigen::Vector2d::Zero();
  double scale_ = 1;
  Eigen::Vector3d l0_ = Eigen::Vector3d::Zero(), l1_ = Eigen::Vector3d::Zero();
  std::vector<std::vector<int>> buckets_;  // empty: no pencil
};

/// Where a line meets a chain (see the header comment).
struct LineMeeting {
  int chain = -1;
  double along = 0;  ///< position along the chain, in chain points
  Eigen::Vector2d b;
  double radius_px = 0;
  double distance_px = 0;  ///< |signed distance| to the line
};

/// Every meeting of the line l (unit normal: distances in pixels) with the chains, in chain then
/// point order, into `out`; `d` is scratch. With `index` (built on these chains, for this
/// tolerance or a larger one) the chains and blocks the line cannot meet are skipped; with
/// nullptr every point is looked at (the reference the fast path is tested against).
inline void line_meetings(const std::vector<Branch2d>& chains, const ChainIndex* index,
                          const Eigen::Vector3d& l, double tol, std::vector<double>& d,
                          std::vector<LineMeeting>& out) {
  GIMM_CHECK(!index || (tol <= index->tol() && index->size() == chains.size()),
             "line_meetings: the index was built for "
                 << (index ? index->size() : 0) << " chains and tolerance "
                 << (index ? index->tol() : 0) << " px, not " << chains.size() << " and " << tol);
  out.clear();
  const auto search = [&](std::size_t k) {
    const Branch2d& chain = chains[k];
    const std::size_t m = chain.points.size();
    const int ki = static_cast<int>(k);
    // Point j is looked at with d[j - 1], d[j] and d[j + 1]: a crossing between j and j + 1,
    // else a near miss at j.
    const auto visit = [&](std::size_t j) {
      if (j + 1 < m && (d[j] == 0 || (d[j] < 0) != (d[j + 1] < 0))) {
        if (d[j + 1] == 0) return;  // counted at j + 1
        const double t = d[j] / (d[j] - d[j + 1]);
        out.push_back({ki, static_cast<double>(j) + t,
                       chain.points[j] + t * (chain.points[j + 1] - chain.points[j]),
                       chain.radius_px[j] + t * (chain.radius_px[j + 1] - chain.radius_px[j]),
                       0.0});
        return;
      }
      const double ad = std::abs(d[j]);
      if (!(ad <= tol)) return;  // NaN too
      const bool crossing_before = j > 0 && (d[j - 1] < 0) != (d[j] < 0);
      const bool local_min =
          (j == 0 || std::abs(d[j - 1]) > ad) && (j + 1 == m || std::abs(d[j + 1]) >= ad);
      if (local_min && !crossing_before)
        out.push_back({ki, static_cast<double>(j), chain.points[j], chain.radius_px[j], ad});
    };
    if (d.size() < m) d.resize(m);  // grown only: resizing per chain zero-filled it each time
    if (!index) {
      for (std::size_t j = 0; j < m; ++j) d[j] = l.dot(chain.points[j].homogeneous());
      for (std::size_t j = 0; j < m; ++j) visit(j);
      return;
    }
    const detail::ChainBlocks& blocks = index->blocks(k);
    if (blocks.box.side_beyond(l, tol)) return;
    // A skipped block (all its points beyond tol on one side) holds no crossing and no near
    // miss. The next block's first point is its last, so beyond tol as well: visit() returns
    // there before it reads d[j - 1], which this block left unset.
    for (std::size_t q = 0; q < blocks.blocks.size(); ++q) {
      const std::size_t first = q * detail::ChainBlocks::kPoints,
                        last = std::min(first + detail::ChainBlocks::kPoints, m - 1);
      if (blocks.blocks[q].side_beyond(l, tol)) continue;
      for (std::size_t j = first; j <= last; ++j) d[j] = l.dot(chain.points[j].homogeneous());
      for (std::size_t j = first; j < last || (j == last && last + 1 == m); ++j) visit(j);
    }
  };
  if (!index) {
    for (std::size_t k = 0; k < chains.size(); ++k) search(k);
    return;
  }
  for (const int k : index->chains_for(l)) search(static_cast<std::size_t>(k));
}

}  // namespace gimm
