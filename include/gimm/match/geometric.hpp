#pragma once
/// The training-free geometric matcher: epipolar constraint plus continuity along the
/// centerlines, solved by dynamic programming (the classical two-view coronary reconstruction,
/// e.g. Blondel et al. 2006), with exact F from the cameras.
///
/// 1. Vessels per view: the given masks, or segment_vessels() of the images (vesselness.hpp,
///    scales from the cameras' magnification). Centerline graph per view (centerline_graph.hpp);
///    segmented, without the chains that look like the catheter or a field edge
///    (catheter_cue.hpp).
/// 2. For each branch of A, samples every `sample_px` along it. The candidates of a sample a are
///    the crossings of its epipolar line F a with B's centerline chains (sub-pixel, between two
///    chain pixels whose signed line distances differ in sign), and the chain pixels that pass
///    within `epipolar_tolerance_px` of the line without crossing it (tips, grazing vessels, a
///    line that is off because the geometry is), found by line_meetings() with B's chains
///    indexed around B's epipole (epipolar_meetings.hpp). Each candidate is triangulated
///    (midpoint of the two viewing rays); candidates outside the heart sphere (heart_radius_mm
///    around the isocentre) are not considered.
/// 3. Along the branch, a chain DP (Viterbi) chooses one candidate or "no match" per sample:
///      unary     w_epipolar (d / tol)^2 + w_radius |ra - rb| / max(ra, rb) + w_intensity |Ia - Ib|
///                (no match: no_match_cost)
///      pairwise  w_step log(|X_i - X_{i-1}| / e)^2, e = the A step back-projected to the depth
///                of X (a vessel foreshortened in A has a longer 3D step: log-symmetric, mild),
///                + w_switch when the two candidates lie on different B chains,
///                + w_order when they lie on one B chain and the second goes back along it
///                (each candidate is two states, walking its chain forwards or backwards, so
///                ordering stays a first-order term; turning round costs w_order too);
///                0 next to "no match" (a gap breaks continuity, which costs no_match_cost).
///    Min-marginals (forward + backward) give each sample's best state and its confidence: the
///    margin between the best state and the best state that puts b elsewhere (> 2 px away) or
///    declines to match.
/// 4. The same from B to A (F transposed). An A->B match is consistent when the B->A solution
///    at the B sample nearest to b (within consistency_px) maps back within consistency_px of a;
///    A match is ambiguous when another match puts a (or b) at the same place (overlap_px) with
///    its partner elsewhere (> ambiguity_px): two vessels overlap there in one view. When a view
///    was segmented, an A chain whose ends disagree in depth with every chain meeting them is off
///    the tree (off_tree_chains: a vessel matched to a rib or spine edge). Inconsistent,
///    ambiguous and off-tree matches each keep a tenth of their margin, so they rank after the
///    others; matches whose margin is below min_confidence (min_confidence_segmented when a view
///    was segmented) are not reported, and a place (a, b) that two chains both match (they meet
///    at a junction pixel) is reported once.
/// 5. The confidence that ranks the matches is the margin times how well the match is placed
///    (GeometricOptions::rank_unary): thin vessels, near the line, away from chain ends, and
///    when segmenting, not on a long unbranched chain.
/// Matches carry the triangulated point (mm, world frame): the tree reconstructed on the way.
#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <future>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/core/image.hpp"
#include "gimm/geometry/camera.hpp"
#include "gimm/geometry/epipolar.hpp"
#include "gimm/geometry/two_rays.hpp"
#include "gimm/match/catheter_cue.hpp"
#include "gimm/match/centerline_graph.hpp"
#include "gimm/match/epipolar_meetings.hpp"
#include "gimm/match/field_of_view.hpp"
#include "gimm/match/pair_matcher.hpp"
#include "gimm/match/vesselness.hpp"

namespace gimm {

struct GeometricOptions {
  double sample_px = 2.0;              ///< spacing of the samples along each branch
  double epipolar_tolerance_px = 3.0;  ///< near-miss candidates up to this far from the line
  // Weights chosen on a tuning set of 8 phantom patients (seed 11), not on the test split:
  // docs/geometric-matcher.md. The intensity term is off: the views' windows differ, and on
  // the tuning set it cost 0.03 in Prec@3px.
  double no_match_cost = 10.0;
  double w_epipolar = 1.0, w_radius = 1.0, w_intensity = 0.0, w_step = 1.0, w_switch = 0.5;
  /// Ordering along a B chain: consecutive samples of an A branch that stay on one B chain move
  /// along it in one direction; going back, or turning round, costs this. 0 (default): no
  /// ordering term. On the tuning set it did not pay (docs/geometric-matcher.md): the 3D step
  /// term already keeps the walk on course, and the states double (4x the DP's work).
  double w_order = 0.0;
  /// Ranking. The DP margin saturates at no_match_cost when nothing in B rivals a sample, so
  /// it does not say which of the unrivalled matches are placed best. The reported confidence
  /// is the margin times exp(-(rank_unary u + r / rank_radius_px + rank_chain_end e)), u the
  /// match's unary cost, r the A vessel's radius in pixels (a wide vessel places its
  /// centerline less precisely, in pixels) and e = 1 on the first and last two samples of a
  /// chain (thinning bends there, at junctions and tips). Chosen on the tuning sets (256 and
  /// 512 px, docs/geometric-matcher.md); the minimum confidences below filter the margin.
  double rank_unary = 2.5, rank_radius_px = 2.0, rank_chain_end = 1.0;
  /// When a view was segmented, a match on a chain (of A or B) longer than long_chain_mm also
  /// keeps exp(-(length - long_chain_mm) / long_chain_decay_mm) of its confidence: long
  /// unbranched chains are spine and rib edges (and, on real images, catheters); coronary
  /// branches between two bifurcations are shorter. 0 = off.
  double long_chain_mm = 60.0, long_chain_decay_mm = 10.0;
  double min_confidence = 0.5;  ///< matches with a smaller margin are not reported
  /// The same when a view was segmented: its centerlines also hold what is not vessel (spine and
  /// rib edges), so a match must win by more (tuning set: Prec@3px 0.73 -> 0.79, coverage 0.43
  /// -> 0.20).
  double min_confidence_segmented = 1.0;
  /// The two minimum margins hold at this many detector pixels per mm at the isocentre (the
  /// phantom datasets at 256 px: 1000 px focal length, 750 mm to the isocentre) and grow in
  /// proportion to the pair's own: samples are every sample_px pixels, so a finer image has
  /// more samples, and more matches above a fixed margin, per mm of vessel, and the top K of a
  /// sparse pair reach further down. On the 512 px tuning set the thresholds that keep the
  /// 256 px share of the K slots were twice the 256 px ones, with masks and segmenting
  /// (docs/geometric-matcher.md). Coarser images keep the thresholds as given: nothing was
  /// measured there, and at 128 px half the threshold let weak matches into the top of an
  /// exact scene's. 0 = the thresholds as given, at any resolution.
  double reference_px_per_mm = 4.0 / 3.0;
  /// Candidates triangulating farther than this from the isocentre (where the two principal
  /// axes meet: the C-arm centres the heart) are not considered; 0 = no limit. Ribs, spine and
  /// catheters outside the heart are found by segmentation and are consistent 3D structures.
  double heart_radius_mm = 80.0;
  /// Tree prior, when a view was segmented: A chains that meet at a junction (ends within
  /// junction_px) meet in 3D too, so the matches nearest their ends (within junction_reach_px)
  /// triangulate within junction_mm of each other. A chain that meets matched chains and agrees
  /// with none of them is on something else in B (a rib or spine edge): its matches keep a tenth
  /// of their confidence. 0 = off. Tuning set: 2D mean 8.20 -> 6.96 px; with masks (every chain
  /// is vessel) it only cost coverage, so it is not applied there (docs/geometric-matcher.md).
  double junction_mm = 5.0;
  double junction_px = 4.0, junction_reach_px = 6.0;
  double consistency_px = 3.0;
  double overlap_px = 2.0;    ///< matches this close in one view claim the same place...
  double ambiguity_px = 6.0;  ///< ...and are ambiguous when their partners are this far apart
  int min_branch_px = 5;      ///< shorter centerline chains are dropped
  /// When a view was segmented, its chains that look like the catheter or a field edge are
  /// dropped before matching (catheter_cue.hpp; off: min_length_mm and field_edge_px 0). On the
  /// clinical-style tuning set (6 patients, seed 11) it took the share of matches off the tree from
  /// 0.53 to 0.31 and coverage at K = 20 from 0.25 to 0.38 (docs/geometric-matcher.md).
  CatheterCueOptions catheter;
  bool use_masks = true;  ///< dataset masks when the pair has them; else segment the images
  SegmentationOptions segmentation;  ///< scales are replaced by vessel_scales() of the cameras
  bool scales_from_cameras = true;
  /// The two views' vessels, then the two matching directions, on two threads (same result).
  bool two_threads = true;
};

struct GeometricMatch {
  Eigen::Vector2d a, b;
  double confidence = 0;  ///< the ranking: margin x placement (GeometricOptions::rank_unary)
  double margin = 0;      ///< the DP margin, after the tenths below (what is thresholded)
  double placement = 1;   ///< how well the match is placed, in (0, 1]
  Eigen::Vector3d world;  ///< triangulated, mm
  bool consistent = false;
  bool unique = false;  ///< no other match claims a or b for a place elsewhere in the other view
  bool on_tree = true;  ///< its A chain is not off the tree (GeometricOptions::junction_mm)
  int branch = -1;      ///< the A branch (index in A's centerline graph) and the sample along it
  int sample = -1;
};

/// One view as the matcher sees it.
struct VesselView {
  const Image<float>* image = nullptr;  ///< optional: intensity term when both views have one
  Image<std::uint8_t> mask;
  bool segmented = false;  ///< the mask was segmented from the image, not given
  CenterlineGraph2d graph;
  std::size_t catheter_chains = 0;  ///< chains dropped as catheter-like (catheter_cue.hpp)
  Camerad camera;
  /// The pair's isocentre (pair_isocenter) the view was prepared at: its pixels per mm, the
  /// depth the matcher's thresholds are scaled at. Computed once per pair.
  Eigen::Vector3d isocenter = Eigen::Vector3d::Zero();
};

namespace detail {

struct Candidate {
  Eigen::Vector2d b;
  Eigen::Vector3d world;
  int chain = -1;
  double along = 0;  ///< position along the B chain, in chain points (sub-point at crossings)
  double unary = 0;
  double px_per_mm = 1;  ///< detector pixels per mm of the source view at `world`
};

/// The matches with each place (a, b) once: a skeleton's junction pixel starts or ends every
/// chain that meets there, so each of them may match it. The most confident stays, where the
/// first of them was (the order keeps consecutive samples of a chain together).
inline std::vector<GeometricMatch> one_per_place(std::vector<GeometricMatch> matches) {
  using Place = std::array<double, 4>;
  const auto place = [](const GeometricMatch& m) {
    return Place{m.a.x(), m.a.y(), m.b.x(), m.b.y()};
  };
  std::map<Place, std::size_t> best;  // place -> index of its most confident match
  for (std::size_t k = 0; k < matches.size(); ++k) {
    const auto [at, inserted] = best.emplace(place(matches[k]), k);
    if (!inserted && matches[k].confidence > matches[at->second].confidence) at->second = k;
  }
  if (best.size() == matches.size()) return matches;
  std::vector<GeometricMatch> kept;
  for (const GeometricMatch& m : matches)
    if (const auto at = best.find(place(m)); at != best.end()) {
      kept.push_back(matches[at->second]);
      best.erase(at);  // the place is taken
    }
  return kept;
}

/// Detector pixels per mm at world point X (focal length over depth; orthographic: K's scale).
inline double pixels_per_mm(const Camerad& camera, const Eigen::Vector3d& X) {
  if (camera.is_orthographic()) return camera.K()(0, 0);
  const double depth = (camera.R() * X + camera.t()).z();
  return depth > 0 ? camera.K()(0, 0) / depth : camera.K()(0, 0);
}

inline double bilinear(const Image<float>& im, const Eigen::Vector2d& p) {
  const double u = std::clamp(p.x(), 0.0, im.cols() - 1.0),
               v = std::clamp(p.y(), 0.0, im.rows() - 1.0);
  const int c0 = std::min(static_cast<int>(u), im.cols() - 1),
            r0 = std::min(static_cast<int>(v), im.rows() - 1);
  const int c1 = std::min(c0 + 1, im.cols() - 1), r1 = std::min(r0 + 1, im.rows() - 1);
  const double fu = u - c0, fv = v - r0;
  return (1 - fv) * ((1 - fu) * im(r0, c0) + fu * im(r0, c1)) +
         fv * ((1 - fu) * im(r1, c0) + fu * im(r1, c1));
}

/// Matches bucketed by one of their two points (a when keyed_by_a), in square cells of `cell`
/// pixels over the points' bounding box (each cell's matches in ascending order, stored one cell
/// after another): visit() calls back every match within `radius` (<= cell) of a point.
class PointGrid {
 public:
  PointGrid(const std::vector<GeometricMatch>& matches, bool by_a, double cell)
      : keyed_by_a(by_a), matches_(matches), cell_(std::max(cell, 1e-6)) {
    if (matches.empty()) return;
    Eigen::Vector2d lo = at(0), hi = lo;
    for (std::size_t k = 0; k < matches.size(); ++k) {
      GIMM_CHECK(at(k).allFinite(), "geometric matcher: a match has a non-finite point");
      lo = lo.cwiseMin(at(k)), hi = hi.cwiseMax(at(k));
    }
    // Cells double in size while there are more than max(65536, 16 per match) of them.
    const long most = std::max<long>(1 << 16, 16 * static_cast<long>(matches.size()));
    cell_ = std::max(cell_, (hi - lo).maxCoeff() / 2048);
    for (;; cell_ *= 2) {
      x0_ = cell_of(lo.x()), y0_ = cell_of(lo.y());
      nx_ = cell_of(hi.x()) - x0_ + 1, ny_ = cell_of(hi.y()) - y0_ + 1;
      if (nx_ * ny_ <= most) break;
    }
    start_.assign(static_cast<std::size_t>(nx_ * ny_ + 1), 0);
    for (std::size_t k = 0; k < matches.size(); ++k) ++start_[index(at(k)) + 1];
    for (std::size_t c = 1; c < start_.size(); ++c) start_[c] += start_[c - 1];
    order_.resize(matches.size());
    std::vector<std::size_t> fill(start_.begin(), start_.end() - 1);
    for (std::size_t k = 0; k < matches.size(); ++k) order_[fill[index(at(k))]++] = k;
  }
  template <class F>
  void visit(const Eigen::Vector2d& p, double radius, F&& f) const {
    if (order_.empty()) return;
    const long cx = cell_of(p.x()) - x0_, cy = cell_of(p.y()) - y0_;
    for (long y = cy - 1; y <= cy + 1; ++y)
      for (long x = cx - 1; x <= cx + 1; ++x) {
        if (x < 0 || y < 0 || x >= nx_ || y >= ny_) continue;
        const auto c = static_cast<std::size_t>(y * nx_ + x);
        for (std::size_t i = start_[c]; i < start_[c + 1]; ++i)
          if ((at(order_[i]) - p).norm() <= radius) f(order_[i]);
      }
  }
  const bool keyed_by_a;

 private:
  const Eigen::Vector2d& at(std::size_t k) const {
    return keyed_by_a ? matches_[k].a : matches_[k].b;
  }
  long cell_of(double x) const { return static_cast<long>(std::floor(x / cell_)); }
  std::size_t index(const Eigen::Vector2d& p) const {
    return static_cast<std::size_t>((cell_of(p.y()) - y0_) * nx_ + (cell_of(p.x()) - x0_));
  }
  const std::vector<GeometricMatch>& matches_;
  double cell_;
  long x0_ = 0, y0_ = 0, nx_ = 0, ny_ = 0;
  std::vector<std::size_t> start_, order_;  // cell c holds order_[start_[c] .. start_[c + 1])
};

/// The tree prior (GeometricOptions::junction_mm): per chain of `graph` (the view the matches
/// start from), whether it is off the tree. Each chain end with a match within
/// junction_reach_px (its first or last matched sample) is compared with the other chains' such
/// ends within junction_px of it: the two chains agree when these matches triangulate within
/// junction_mm. A chain is off the tree when it meets matched chains but agrees with none of
/// them at any of its ends. (At a crossing of two vessels at different depths each chain still
/// agrees with the one it continues into.)
inline std::vector<bool> off_tree_chains(const CenterlineGraph2d& graph,
                                         const std::vector<GeometricMatch>& matches,
                                         const GeometricOptions& o) {
  const std::size_t n = graph.branches.size();
  std::vector<long> first(n, -1), last(n, -1);  // per chain: its first and last matched sample
  for (std::size_t k = 0; k < matches.size(); ++k) {
    const int c = matches[k].branch;
    GIMM_CHECK(c >= 0 && static_cast<std::size_t>(c) < n,
               "geometric matcher: a match names chain " << c << " of " << n);
    if (first[c] < 0 || matches[k].sample < matches[first[c]].sample) first[c] = long(k);
    if (last[c] < 0 || matches[k].sample > matches[last[c]].sample) last[c] = long(k);
  }
  std::vector<GeometricMatch> ends;  // the match nearest a chain's end, .a moved to the end
  for (std::size_t c = 0; c < n; ++c) {
    const std::vector<Eigen::Vector2d>& points = graph.branches[c].points;
    if (first[c] < 0 || points.empty()) continue;
    for (const auto& [end, k] : {std::pair{points.front(), first[c]}, {points.back(), last[c]}}) {
      if ((matches[k].a - end).norm() > o.junction_reach_px) continue;
      GeometricMatch e = matches[k];
      e.a = end;
      ends.push_back(e);
    }
  }
  std::vector<char> agrees(n, 0), meets(n, 0);
  const PointGrid grid(ends, true, o.junction_px);
  for (const GeometricMatch& e : ends)
    grid.visit(e.a, o.junction_px, [&](std::size_t k) {
      if (ends[k].branch == e.branch) return;  // a closed loop meets itself
      meets[e.branch] = 1;
      if ((ends[k].world - e.world).norm() <= o.junction_mm) agrees[e.branch] = 1;
    });
  std::vector<bool> off(n);
  for (std::size_t c = 0; c < n; ++c) off[c] = meets[c] && !agrees[c];
  return off;
}

/// The ordering term between consecutive samples' candidates p then c, each walking its B chain
/// forwards or backwards: `w` when both are on one chain and c turns round or goes back along it
/// (more than half a chain point: a foreshortened stretch may stand still); else 0.
inline double ordering_cost(const Candidate& p, bool p_forwards, const Candidate& c,
                            bool c_forwards, double w) {
  if (p.chain != c.chain) return 0.0;  // a new chain: any direction
  const double move = c.along - p.along;
  const bool back = c_forwards ? move < -0.5 : move > 0.5;
  return c_forwards != p_forwards || back ? w : 0.0;
}

/// Points every `step` pixels of arc length along a chain (the first point included).
inline std::vector<std::size_t> resample_chain(const Branch2d& chain, double step) {
  std::vector<std::size_t> out{0};
  double since = 0;
  for (std::size_t k = 1; k < chain.points.size(); ++k) {
    since += (chain.points[k] - chain.points[k - 1]).norm();
    if (since >= step - 1e-9) {
      out.push_back(k);
      since = 0;
    }
  }
  return out;
}

}  // namespace detail

/// Min-marginals of a chain: cost[i][s] = the least total cost of a state sequence that has state
/// s at position i, where a sequence costs sum_i unary(i, s_i) + sum_{i>0} pair(i, s_{i-1}, s_i).
/// Forward (alpha) and backward (beta) passes, O(n S^2); each pair cost is evaluated once and
/// kept for both passes, unless the chain has more than `cache_limit` of them (then evaluated in
/// each pass: the same values, without n S^2 of memory).
template <class Unary, class Pair>
std::vector<std::vector<double>> chain_min_marginals(const std::vector<std::size_t>& states,
                                                     const Unary& unary, const Pair& pair,
                                                     std::size_t cache_limit = 1 << 22) {
  const std::size_t n = states.size();
  const double inf = std::numeric_limits<double>::infinity();
  std::size_t pairs = 0;
  for (std::size_t i = 1; i < n; ++i) pairs += states[i - 1] * states[i];
  // costs[i][sp * states[i] + s] = pair(i, sp, s)
  std::vector<std::vector<double>> costs(n), alpha(n), beta(n);
  const bool cached = pairs <= cache_limit;
  for (std::size_t i = 1; i < n && cached; ++i) {
    costs[i].resize(states[i - 1] * states[i]);
    for (std::size_t sp = 0; sp < states[i - 1]; ++sp)
      for (std::size_t s = 0; s < states[i]; ++s) costs[i][sp * states[i] + s] = pair(i, sp, s);
  }
  const auto cost = [&](std::size_t i, std::size_t sp, std::size_t s) {
    return cached ? costs[i][sp * states[i] + s] : pair(i, sp, s);
  };
  for (std::size_t i = 0; i < n; ++i) {
    alpha[i].assign(states[i], inf);
    for (std::size_t s = 0; s < states[i]; ++s) {
      double best = i == 0 ? 0.0 : inf;
      if (i > 0)
        for (std::size_t sp = 0; sp < states[i - 1]; ++sp)
          best = std::min(best, alpha[i - 1][sp] + cost(i, sp, s));
      alpha[i][s] = best + unary(i, s);
    }
  }
  std::vector<double> ahead;  // unary(i + 1, sn), once per i
  for (std::size_t i = n; i-- > 0;) {
    beta[i].assign(states[i], i + 1 == n ? 0.0 : inf);
    if (i + 1 == n) continue;
    ahead.resize(states[i + 1]);
    for (std::size_t sn = 0; sn < states[i + 1]; ++sn) ahead[sn] = unary(i + 1, sn);
    for (std::size_t s = 0; s < states[i]; ++s)
      for (std::size_t sn = 0; sn < states[i + 1]; ++sn)
        beta[i][s] = std::min(beta[i][s], cost(i + 1, s, sn) + ahead[sn] + beta[i + 1][sn]);
  }
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t s = 0; s < states[i]; ++s) alpha[i][s] += beta[i][s];
  return alpha;
}

/// One direction (from `from` to `to`, F maps `from` points to lines in `to`): per branch of
/// `from`, the DP's matches.
inline std::vector<GeometricMatch> match_branches_dp(const VesselView& from, const VesselView& to,
                                                     const Eigen::Matrix3d& F,
                                                     const Eigen::Vector3d& isocenter,
                                                     const GeometricOptions& o) {
  std::vector<GeometricMatch> out;
  const bool with_intensity = from.image && to.image && o.w_intensity > 0;
  const double tol = o.epipolar_tolerance_px;
  // The target chains indexed by the lines that can reach them; every line F a passes through
  // the epipole of `to`.
  const ChainIndex index(to.graph.branches, tol, detail::lines_common_point(F));
  const bool segmented = from.segmented || to.segmented;
  std::vector<double> to_length_px;  // of the target chains, for the long-chain term
  for (const Branch2d& chain : to.graph.branches)
    to_length_px.push_back(detail::chain_length_px(chain));
  std::vector<double> d;              // line_meetings' scratch
  std::vector<LineMeeting> meetings;  // of the current sample's line
  // One candidate set per sample.
  const auto candidates_of = [&](const Eigen::Vector2d& a, double ra, double ia) {
    std::vector<detail::Candidate> cands;
    Eigen::Vector3d l = F * a.homogeneous();
    const double n = l.head<2>().norm();
    if (!(n > 0) || !l.allFinite()) return cands;
    l /= n;
    const Ray<double> ray_a = from.camera.ray(a.x(), a.y());
    line_meetings(to.graph.branches, &index, l, tol, d, meetings);
    for (const LineMeeting& mt : meetings) {
      const auto X = two_ray_midpoint(ray_a, to.camera.ray(mt.b.x(), mt.b.y()));
      if (!X || (o.heart_radius_mm > 0 && (*X - isocenter).norm() > o.heart_radius_mm)) continue;
      const double rb = mt.radius_px, off = mt.distance_px / tol;
      detail::Candidate c{mt.b, *X, mt.chain, mt.along, 0, detail::pixels_per_mm(from.camera, *X)};
      c.unary = o.w_epipolar * off * off + o.w_radius * std::abs(ra - rb) / std::max({ra, rb, 1.0});
      if (with_intensity)
        c.unary += o.w_intensity * std::abs(ia - detail::bilinear(*to.image, mt.b));
      cands.push_back(c);
    }
    return cands;
  };
  for (std::size_t bi = 0; bi < from.graph.branches.size(); ++bi) {
    const Branch2d& branch = from.graph.branches[bi];
    const int branch_index = static_cast<int>(bi);
    const double branch_length_px = detail::chain_length_px(branch);
    const std::vector<std::size_t> idx = detail::resample_chain(branch, o.sample_px);
    const std::size_t n = idx.size();
    std::vector<std::vector<detail::Candidate>> cand(n);
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Vector2d& a = branch.points[idx[i]];
      cand[i] = candidates_of(a, branch.radius_px[idx[i]],
                              with_intensity ? detail::bilinear(*from.image, a) : 0.0);
    }
    // State s of sample i: 0 = no match; s >= 1 = candidate (s - 1) / 2 walked along its B chain
    // forwards (s odd) or backwards (s even), so the ordering term stays first-order.
    const std::size_t dirs = o.w_order > 0 ? 2 : 1;
    const auto candidate = [&](std::size_t s) { return (s - 1) / dirs; };
    const auto forwards = [&](std::size_t s) { return dirs == 1 || (s - 1) % 2 == 0; };
    std::vector<double> step_px(n, 0.0);  // A step into sample i
    for (std::size_t i = 1; i < n; ++i)
      step_px[i] = (branch.points[idx[i]] - branch.points[idx[i - 1]]).norm();
    const auto pair_cost = [&](std::size_t i, std::size_t s_prev, std::size_t s) {
      if (s_prev == 0 || s == 0) return 0.0;
      const detail::Candidate &p = cand[i - 1][candidate(s_prev)], &c = cand[i][candidate(s)];
      const double expected = step_px[i] / c.px_per_mm;
      const double ratio = std::max((c.world - p.world).norm(), 1e-3) / std::max(expected, 1e-3);
      const double lr = std::log(ratio);
      return o.w_step * lr * lr + (p.chain != c.chain ? o.w_switch : 0.0) +
             detail::ordering_cost(p, forwards(s_prev), c, forwards(s), o.w_order);
    };
    const auto unary = [&](std::size_t i, std::size_t s) {
      return s == 0 ? o.no_match_cost : cand[i][candidate(s)].unary;
    };
    std::vector<std::size_t> states(n);
    for (std::size_t i = 0; i < n; ++i) states[i] = dirs * cand[i].size() + 1;
    const std::vector<std::vector<double>> marginal = chain_min_marginals(states, unary, pair_cost);
    for (std::size_t i = 0; i < n; ++i) {
      std::size_t best = 0;
      for (std::size_t s = 1; s < states[i]; ++s)
        if (marginal[i][s] < marginal[i][best]) best = s;
      if (best == 0) continue;
      const detail::Candidate& c = cand[i][candidate(best)];
      double rival = marginal[i][0];
      for (std::size_t s = 1; s < states[i]; ++s)
        if ((cand[i][candidate(s)].b - c.b).norm() > 2.0) rival = std::min(rival, marginal[i][s]);
      GeometricMatch m;
      m.a = branch.points[idx[i]];
      m.b = c.b;
      m.world = c.world;
      m.margin = rival - marginal[i][best];
      const bool chain_end = std::min(i, n - 1 - i) < 2;
      double misplaced = o.rank_unary * c.unary + branch.radius_px[idx[i]] / o.rank_radius_px +
                         (chain_end ? o.rank_chain_end : 0.0);
      if (segmented && o.long_chain_mm > 0) {
        const double longest_mm =
            std::max(branch_length_px / c.px_per_mm,
                     to_length_px[c.chain] / detail::pixels_per_mm(to.camera, c.world));
        misplaced += std::max(0.0, longest_mm - o.long_chain_mm) / o.long_chain_decay_mm;
      }
      m.placement = std::exp(-misplaced);
      m.branch = branch_index;
      m.sample = static_cast<int>(i);
      out.push_back(m);
    }
  }
  return out;
}

/// One view's working memory: its segmentation's and its centerline graph's (about 12 MB for a
/// 512 x 512 image segmented, 1.5 MB from a mask).
struct ViewBuffers {
  SegmentationBuffers segmentation;
  CenterlineBuffers centerlines;
};

/// A view's vessels and centerlines: from `mask` when given, else segmented from the image;
/// worked out in `buffers`.
/// Vessels outside `field` (when given: the exposed field) are dropped before the centerlines.
inline VesselView vessel_view(const Image<float>* image, const Image<std::uint8_t>* mask,
                              const Camerad& camera, const Eigen::Vector3d& isocenter,
                              const GeometricOptions& o, ViewBuffers& buffers,
                              const Image<std::uint8_t>* field = nullptr) {
  VesselView v;
  v.image = image;
  v.camera = camera;
  v.isocenter = isocenter;
  GIMM_CHECK(image || mask, "geometric matcher: a view has neither an image nor a mask");
  const int rows = mask ? mask->rows() : image->rows(), cols = mask ? mask->cols() : image->cols();
  GIMM_CHECK(camera.rows() == rows && camera.cols() == cols,
             "geometric matcher: the camera is for a " << camera.cols() << " x " << camera.rows()
                                                       << " image, the view is " << cols << " x "
                                                       << rows);
  if (mask) {
    v.mask = *mask;
  } else {
    SegmentationOptions seg = o.segmentation;
    if (o.scales_from_cameras)
      seg.vesselness.scales_px = vessel_scales(detail::pixels_per_mm(camera, isocenter));
    segment_vessels(*image, seg, v.mask, buffers.segmentation, field);
    v.segmented = true;
  }
  if (field) clear_outside(v.mask, *field);
  v.graph = centerline_graph(v.mask, o.min_branch_px, buffers.centerlines);
  if (v.segmented)
    v.catheter_chains = drop_catheter_like_chains(v.graph, detail::pixels_per_mm(camera, isocenter),
                                                  field, o.catheter);
  return v;
}

inline VesselView vessel_view(const Image<float>* image, const Image<std::uint8_t>* mask,
                              const Camerad& camera, const Eigen::Vector3d& isocenter,
                              const GeometricOptions& o) {
  ViewBuffers buffers;
  return vessel_view(image, mask, camera, isocenter, o, buffers);
}

/// ViewBuffers kept between calls, lent one per view being worked on; safe to share between
/// threads. A matcher that keeps them does not allocate, and touch for the first time, a view's
/// working memory for every pair: on the 2-core benchmark machine (a virtual machine, where a
/// page's first touch is dear) a segmented 512 x 512 pair went from 37 to 11 ms
/// (docs/performance.md, "Geometric matcher").
class ViewBufferPool {
 public:
  /// Buffers lent until the lease ends.
  class Lease {
   public:
    explicit Lease(ViewBufferPool& pool) : pool_(pool), buffers_(pool.take()) {}
    Lease(const Lease&) = delete;
    Lease& operator=(const Lease&) = delete;
    ~Lease() { pool_.give(std::move(buffers_)); }
    ViewBuffers& operator*() { return *buffers_; }

   private:
    ViewBufferPool& pool_;
    std::unique_ptr<ViewBuffers> buffers_;
  };

 private:
  std::unique_ptr<ViewBuffers> take() {
    const std::lock_guard<std::mutex> lock(mutex_);
    if (free_.empty()) return std::make_unique<ViewBuffers>();
    std::unique_ptr<ViewBuffers> b = std::move(free_.back());
    free_.pop_back();
    return b;
  }
  void give(std::unique_ptr<ViewBuffers> b) noexcept {
    const std::lock_guard<std::mutex> lock(mutex_);
    try {
      free_.push_back(std::move(b));
    } catch (...) {  // out of memory: the buffers are freed instead of kept
    }
  }
  std::mutex mutex_;
  std::vector<std::unique_ptr<ViewBuffers>> free_;
};

/// How much finer than reference_px_per_mm the pair's images are at the isocentre (the mean of
/// the two views), at least 1; 1 when reference_px_per_mm is 0.
inline double threshold_scale(const Camerad& a, const Camerad& b, const Eigen::Vector3d& iso,
                              const GeometricOptions& o) {
  if (o.reference_px_per_mm == 0) return 1.0;
  const double px_per_mm = 0.5 * (detail::pixels_per_mm(a, iso) + detail::pixels_per_mm(b, iso));
  return std::max(1.0, px_per_mm / o.reference_px_per_mm);
}

/// Both directions, made consistent (see the header comment).
inline std::vector<GeometricMatch> geometric_matches(const VesselView& a, const VesselView& b,
                                                     const GeometricOptions& o) {
  GIMM_CHECK(o.sample_px > 0 && o.epipolar_tolerance_px > 0 && o.no_match_cost >= 0 &&
                 o.consistency_px > 0,
             "geometric matcher: sample_px, epipolar_tolerance_px and consistency_px must be > "
             "0 and no_match_cost >= 0");
  GIMM_CHECK(std::isfinite(o.min_confidence) && o.min_confidence >= 0 &&
                 std::isfinite(o.min_confidence_segmented) && o.min_confidence_segmented >= 0,
             "geometric matcher: the minimum confidences must be finite and >= 0, got "
                 << o.min_confidence << " (masks) and " << o.min_confidence_segmented
                 << " (segmented)");
  GIMM_CHECK(std::isfinite(o.rank_unary) && o.rank_unary >= 0 && std::isfinite(o.rank_radius_px) &&
                 o.rank_radius_px > 0 && std::isfinite(o.rank_chain_end) && o.rank_chain_end >= 0 &&
                 std::isfinite(o.long_chain_mm) && o.long_chain_mm >= 0 &&
                 std::isfinite(o.long_chain_decay_mm) && o.long_chain_decay_mm > 0,
             "geometric matcher: rank_unary, rank_chain_end and long_chain_mm must be finite and "
             ">= 0, rank_radius_px and long_chain_decay_mm finite and > 0, got "
                 << o.rank_unary << ", " << o.rank_chain_end << ", " << o.long_chain_mm << ", "
                 << o.rank_radius_px << ", " << o.long_chain_decay_mm);
  GIMM_CHECK(std::isfinite(o.reference_px_per_mm) && o.reference_px_per_mm >= 0,
             "geometric matcher: reference_px_per_mm must be finite and >= 0, got "
                 << o.reference_px_per_mm);
  GIMM_CHECK(std::isfinite(o.w_order) && o.w_order >= 0,
             "geometric matcher: the ordering cost must be finite and >= 0, got " << o.w_order);
  GIMM_CHECK(std::isfinite(o.junction_mm) && o.junction_mm >= 0 && o.junction_px > 0 &&
                 std::isfinite(o.junction_px) && o.junction_reach_px >= 0 &&
                 std::isfinite(o.junction_reach_px),
             "geometric matcher: junction_mm must be >= 0 and junction_px > 0, junction_reach_px "
             ">= 0, got "
                 << o.junction_mm << ", " << o.junction_px << ", " << o.junction_reach_px);
  GIMM_CHECK(a.isocenter == b.isocenter,
             "geometric matcher: the two views were prepared at different isocentres");
  const Eigen::Matrix3d F = fundamental_from_cameras(a.camera, b.camera);
  const Eigen::Vector3d& iso = a.isocenter;
  const Eigen::Matrix3d Ft = F.transpose();
  std::future<std::vector<GeometricMatch>> ba_later =
      std::async(o.two_threads ? std::launch::async : std::launch::deferred,
                 [&] { return match_branches_dp(b, a, Ft, iso, o); });
  std::vector<GeometricMatch> ab = match_branches_dp(a, b, F, iso, o);
  const std::vector<GeometricMatch> ba = ba_later.get();
  // Another point claiming the same place: an overlap of two vessels in one view, where a
  // point does not tell which vessel it is on.
  // Matches indexed by where they sit in each view, for the neighbour queries below.
  const double reach = std::max(o.overlap_px, o.consistency_px);
  const detail::PointGrid ab_at_a(ab, true, reach), ab_at_b(ab, false, reach);
  const detail::PointGrid ba_at_b(ba, true, reach), ba_at_a(ba, false, reach);  // ba: .a is in B
  // Another match claiming the same place in one view with its partner elsewhere: an overlap of
  // two vessels there, where a point does not tell which vessel it is on.
  const auto claimed_elsewhere = [&](const detail::PointGrid& grid,
                                     const std::vector<GeometricMatch>& set,
                                     const Eigen::Vector2d& here, const Eigen::Vector2d& there) {
    bool found = false;
    grid.visit(here, o.overlap_px, [&](std::size_t k) {
      const GeometricMatch& r = set[k];
      const Eigen::Vector2d& r_there = grid.keyed_by_a ? r.b : r.a;
      found = found || (r_there - there).norm() > o.ambiguity_px;
    });
    return found;
  };
  for (GeometricMatch& m : ab) {
    double nearest = o.consistency_px;
    const GeometricMatch* back = nullptr;
    ba_at_b.visit(m.b, o.consistency_px, [&](std::size_t k) {
      if (const double d = (ba[k].a - m.b).norm(); d <= nearest) {
        nearest = d;
        back = &ba[k];
      }
    });
    m.consistent = back && (back->b - m.a).norm() <= o.consistency_px;
    m.unique =
        !claimed_elsewhere(ab_at_a, ab, m.a, m.b) && !claimed_elsewhere(ba_at_a, ba, m.a, m.b) &&
        !claimed_elsewhere(ab_at_b, ab, m.b, m.a) && !claimed_elsewhere(ba_at_b, ba, m.b, m.a);
  }
  const bool segmented = a.segmented || b.segmented;
  const std::vector<bool> off_tree = segmented && o.junction_mm > 0
                                         ? detail::off_tree_chains(a.graph, ab, o)
                                         : std::vector<bool>();
  for (GeometricMatch& m : ab) {
    m.on_tree = off_tree.empty() || !off_tree[m.branch];
    if (!m.consistent) m.margin *= 0.1;
    if (!m.unique) m.margin *= 0.1;
    if (!m.on_tree) m.margin *= 0.1;
    m.confidence = m.margin * m.placement;
  }
  const double min_confidence = (segmented ? o.min_confidence_segmented : o.min_confidence) *
                                threshold_scale(a.camera, b.camera, iso, o);
  ab.erase(std::remove_if(ab.begin(), ab.end(),
                          [&](const GeometricMatch& m) { return m.margin < min_confidence; }),
           ab.end());
  return detail::one_per_place(std::move(ab));
}

/// The geometric matcher behind the matcher interface. Needs both cameras; uses the pair's
/// vessel masks in dataset mode when `use_masks`, else segments the images.
/// The geometric matcher's result: every matcher's, and what it knows of each match.
struct GeometricPairResult : PairMatchResult {
  std::vector<GeometricMatch> points;
};

class GeometricMatcher : public PairMatcher {
 public:
  explicit GeometricMatcher(GeometricOptions options = {}) : options_(options) {}
  /// With working memory shared beyond this matcher's life (a binding that makes a matcher
  /// per call keeps one pool for all of them).
  GeometricMatcher(GeometricOptions options, std::shared_ptr<ViewBufferPool> buffers)
      : options_(options), buffers_(std::move(buffers)) {
    GIMM_CHECK(buffers_ != nullptr, "geometric matcher: no buffer pool given (null)");
  }
  std::string name() const override { return "geometric"; }
  // With masks it reads only them; segmenting, it reads the images.
  bool needs_images() const override { return !options_.use_masks; }
  /// run()'s result with each match's triangulated point, A branch and margin (`points`, in
  /// the order of result.matches). The matches carry the cameras' F, the one they follow; none
  /// lies outside the exposed fields (the views are cleared outside them first).
  GeometricPairResult run_with_points(const PairInput& pair) const {
    const auto start = std::chrono::steady_clock::now();
    GeometricPairResult r;
    r.points = match_with_points(pair);
    r.matches = to_pair_matches(pair.id, r.points);
    r.matches.F = fundamental_from_cameras(*pair.camera_a, *pair.camera_b);
    r.matches.F_source = "cameras";
    r.candidates = static_cast<int>(r.points.size());
    r.seconds = detail::seconds_since(start);
    return r;
  }
  /// The matches with what the matcher knows of each: its triangulated point, A branch, margin.
  std::vector<GeometricMatch> match_with_points(const PairInput& pair) const {
    GIMM_CHECK(pair.camera_a && pair.camera_b,
               "geometric: pair '" << pair.id << "' has no cameras (the matcher needs both)");
    pair.validate();
    const bool masks = options_.use_masks && pair.mask_a && pair.mask_b;
    GIMM_CHECK(masks || (pair.image_a && pair.image_b),
               "geometric: pair '" << pair.id << "' has neither masks nor images");
    const Eigen::Vector3d iso = pair_isocenter(*pair.camera_a, *pair.camera_b);
    ViewBufferPool::Lease buffers_a(*buffers_), buffers_b(*buffers_);
    std::future<VesselView> b_later =
        std::async(options_.two_threads ? std::launch::async : std::launch::deferred, [&] {
          return vessel_view(pair.image_b, masks ? pair.mask_b : nullptr, *pair.camera_b, iso,
                             options_, *buffers_b, pair.field_b);
        });
    const VesselView a = vessel_view(pair.image_a, masks ? pair.mask_a : nullptr, *pair.camera_a,
                                     iso, options_, *buffers_a, pair.field_a);
    const VesselView b = b_later.get();
    return geometric_matches(a, b, options_);
  }
  static PairMatches to_pair_matches(const std::string& id, const std::vector<GeometricMatch>& g) {
    PairMatches m;
    m.pair = id;
    for (const auto& x : g) m.add(x.a, x.b, x.confidence);
    return m;
  }

 protected:
  PairMatchResult run_method(const PairInput& pair) const override { return run_with_points(pair); }

 private:
  GeometricOptions options_;
  // Shared by copies of the matcher; two buffers per pair being matched at once.
  std::shared_ptr<ViewBufferPool> buffers_ = std::make_shared<ViewBufferPool>();
};

}  // namespace gimm
