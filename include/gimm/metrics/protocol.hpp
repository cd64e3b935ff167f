#pragma once
/// The reference evaluation protocol (reference-notes.md, "The evaluation protocol") for one
/// view pair, match by match.
///
/// Matches are ranked by confidence (descending, ties by ascending index); the evaluation keeps
/// the first K (summary.hpp). Each kept match i, a_i <-> b_i, is scored in both directions:
///   A->B: source s = a_i, predicted target p = b_i, source labels = the dense labels' A points,
///         target labels = their B points, source mask = view A's vessel mask;
///   B->A: the same with the roles of A and B exchanged.
/// In one direction:
///   - the match is dropped (not scored) when the source point, rounded to the nearest pixel
///     (u = column, v = row, pixel centres at integers, std::lround: halves away from zero), is
///     off the image or on a zero mask pixel, or is not finite, or the pair has no labels;
///   - j = the label whose source-side point is nearest to s (ties: the lowest index);
///     expected = label j's target-side point; 2D error = |p - expected| in pixels;
///   - t = the label whose target-side point is nearest to p (ties: the lowest index);
///     3D error = |world_j - world_t| in mm.
/// Independently of direction and mask, every match also gets its symmetric epipolar distance
/// under the true F, sqrt(d(b, F a)^2 + d(a, F^T b)^2) in pixels (the exact-geometry check).
///
/// Nearest neighbours are found by brute force over the labels: O(matches x labels) per pair.
#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "gimm/core/image.hpp"
#include "gimm/geometry/epipolar.hpp"
#include "gimm/match/matches.hpp"
#include "gimm/metrics/truth.hpp"

namespace gimm {

/// The outcome of one match in one direction.
struct DirectionScore {
  bool scored = false;                                         ///< source on the source mask
  double error_px = std::numeric_limits<double>::quiet_NaN();  ///< 2D error, pixels
  double error_mm = std::numeric_limits<double>::quiet_NaN();  ///< 3D error, mm
};

struct RankedMatch {
  std::size_t index = 0;  ///< the match's index in the predictions
  DirectionScore ab, ba;  ///< A->B and B->A
  double epipolar_px = std::numeric_limits<double>::quiet_NaN();  ///< under the true F
};

/// Every match of one pair scored, in rank order, plus what the breakdowns group by.
struct PairScore {
  std::string id, system, class_pair;
  std::size_t matches = 0;          ///< predicted matches
  bool has_predictions = true;      ///< false: no predictions file (scored as zero matches)
  std::vector<RankedMatch> ranked;  ///< the first min(max_rank, matches) matches by rank
};

/// True when `p` rounded to the nearest pixel is inside `mask` and nonzero there; without a
/// mask, when p is finite.
inline bool on_mask(const Image<std::uint8_t>* mask, const Eigen::Vector2d& p) {
  if (!p.allFinite()) return false;
  if (!mask) return true;
  if (std::abs(p.x()) > 1e9 || std::abs(p.y()) > 1e9) return false;
  const long col = std::lround(p.x()), row = std::lround(p.y());
  return row >= 0 && col >= 0 && row < mask->rows() && col < mask->cols() &&
         (*mask)(static_cast<int>(row), static_cast<int>(col)) != 0;
}

/// Index of the point of `points` nearest to p (ties: lowest index); -1 if empty.
inline long nearest_point(const std::vector<Eigen::Vector2d>& points, const Eigen::Vector2d& p) {
  long best = -1;
  double best_d = std::numeric_limits<double>::infinity();
  for (std::size_t n = 0; n < points.size(); ++n) {
    const double d = (points[n] - p).squaredNorm();
    if (d < best_d) {
      best_d = d;
      best = static_cast<long>(n);
    }
  }
  return best;
}

/// One direction of the protocol: source labels `from`, target labels `to` (paired by index),
/// their 3D positions `world`, the source mask (nullptr: everywhere vessel).
inline DirectionScore score_direction(const Eigen::Vector2d& source, const Eigen::Vector2d& target,
                                      const std::vector<Eigen::Vector2d>& from,
                                      const std::vector<Eigen::Vector2d>& to,
                                      const std::vector<Eigen::Vector3d>& world,
                                      const Image<std::uint8_t>* source_mask) {
  DirectionScore s;
  if (from.empty() || !target.allFinite() || !on_mask(source_mask, source)) return s;
  const long j = nearest_point(from, source);
  const long t = nearest_point(to, target);
  s.scored = true;
  s.error_px = (target - to[static_cast<std::size_t>(j)]).norm();
  s.error_mm = (world[static_cast<std::size_t>(j)] - world[static_cast<std::size_t>(t)]).norm();
  return s;
}

/// Scores the first `max_rank` matches by rank (max_rank < 0: all) in both directions.
inline PairScore score_pair(const PairTruth& truth, const PairMatches& matches,
                            long max_rank = -1) {
  matches.validate("matches of " + truth.id);
  PairScore out;
  out.id = truth.id;
  out.system = truth.system();
  out.class_pair = class_pair_key(truth);
  out.matches = matches.size();
  std::vector<Eigen::Vector2d> la, lb;
  std::vector<Eigen::Vector3d> world;
  for (const auto& c : truth.dense) {
    la.push_back(c.a);
    lb.push_back(c.b);
    world.push_back(c.world);
  }
  for (const std::size_t i : rank_by_confidence(matches.confidence, max_rank)) {
    const Eigen::Vector2d& a = matches.points_a[i];
    const Eigen::Vector2d& b = matches.points_b[i];
    RankedMatch r;
    r.index = i;
    r.ab = score_direction(a, b, la, lb, world, truth.mask_a.get());
    r.ba = score_direction(b, a, lb, la, world, truth.mask_b.get());
    if (!truth.F.isZero())  // a user's truth may come without F
      r.epipolar_px = std::sqrt(symmetric_epipolar_distance_sq<double>(truth.F, a, b));
    out.ranked.push_back(r);
  }
  return out;
}

/// The score of a pair without a predictions file: no matches.
inline PairScore missing_pair(const PairTruth& truth) {
  PairScore out;
  out.id = truth.id;
  out.system = truth.system();
  out.class_pair = class_pair_key(truth);
  out.has_predictions = false;
  return out;
}

}  // namespace gimm
