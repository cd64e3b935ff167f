#pragma once
/// Which segmented centerline chains are not vessels: the guiding catheter and the edges of the
/// exposed field. Segmenting an angiogram finds every dark tube, and the catheter is the darkest
/// and straightest of them: one 3D object in both views, so the epipolar geometry accepts it and
/// the geometric matcher matched it before anything else (docs/geometric-matcher.md, "On the
/// clinical-style views"). Two cues, each a property of one chain:
/// - straight and long: chord / length >= straightness over at least min_length_mm (at the
///   isocentre's magnification). Coronary branches curve over the heart; between two junctions
///   they rarely run 20 mm straight. The catheter's shaft does, and so does a shutter's edge.
/// - leaving the field: an end within field_edge_px plus its radius of the exposed field's edge
///   (or the image's border: thinning pulls an end back by about the radius), on a chain at least
///   edge_min_length_mm long with an even calibre (coefficient of variation of the radius at most
///   even_calibre). The catheter enters every frame from its edge at a constant calibre; a branch
///   that leaves the field tapers, but the RCA does not much, so this cue is off by default
///   (field_edge_px).
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/core/image.hpp"
#include "gimm/match/centerline_graph.hpp"

namespace gimm {

struct CatheterCueOptions {
  double straightness = 0.95;  ///< chord / length at or above this...
  double min_length_mm = 20;   ///< ...over at least this: not a vessel; 0 = cue off
  /// An end this near the field's edge, beyond its radius, leaves the field; 0 = off (the
  /// default: on the clinical-style tuning set the RCA, which runs off the field at an even
  /// calibre, was dropped with the catheter, and Prec@5px fell from 0.84 to 0.79).
  int field_edge_px = 0;
  double edge_min_length_mm = 10;  ///< ...on a chain at least this long...
  double even_calibre = 0.25;      ///< ...whose radius std / mean is at most this
};

namespace detail {

/// Pixels from p to the nearest pixel outside `field` (or outside the image when field is
/// null), up to `limit` (Chebyshev distance: square rings around p).
inline int distance_to_field_edge(const Eigen::Vector2d& p, int rows, int cols,
                                  const Image<std::uint8_t>* field, int limit) {
  const int r0 = static_cast<int>(std::lround(p.y())), c0 = static_cast<int>(std::lround(p.x()));
  const auto outside = [&](int r, int c) {
    if (r < 0 || c < 0 || r >= rows || c >= cols) return true;
    return field && (*field)(r, c) == 0;
  };
  for (int d = 0; d < limit; ++d)
    for (int dr = -d; dr <= d; ++dr) {
      const int step = (dr == -d || dr == d) ? 1 : 2 * d;  // whole top/bottom rows, else sides
      for (int dc = -d; dc <= d; dc += std::max(step, 1))
        if (outside(r0 + dr, c0 + dc)) return d;
    }
  return limit;
}

inline double radius_variation(const Branch2d& chain) {
  if (chain.radius_px.empty()) return 0;
  double sum = 0, sum2 = 0;
  for (double r : chain.radius_px) sum += r, sum2 += r * r;
  const double n = static_cast<double>(chain.radius_px.size()), mean = sum / n;
  return mean > 0 ? std::sqrt(std::max(0.0, sum2 / n - mean * mean)) / mean : 0;
}

}  // namespace detail

/// Per chain of `graph`: true when it looks like a catheter or a field edge (see above).
/// px_per_mm: detector pixels per mm at the isocentre; field: the exposed field (may be null).
inline std::vector<bool> catheter_like_chains(const CenterlineGraph2d& graph, double px_per_mm,
                                              const Image<std::uint8_t>* field,
                                              const CatheterCueOptions& o) {
  GIMM_CHECK(std::isfinite(px_per_mm) && px_per_mm > 0,
             "catheter cue: pixels per mm must be finite and > 0, got " << px_per_mm);
  GIMM_CHECK(std::isfinite(o.straightness) && o.straightness > 0 && o.straightness <= 1 &&
                 std::isfinite(o.min_length_mm) && o.min_length_mm >= 0 &&
                 std::isfinite(o.edge_min_length_mm) && o.edge_min_length_mm >= 0 &&
                 std::isfinite(o.even_calibre) && o.even_calibre >= 0 && o.field_edge_px >= 0 &&
                 o.field_edge_px <= 1000,
             "catheter cue: straightness must be in (0, 1], lengths and even_calibre finite and "
             ">= 0, field_edge_px in [0, 1000], got "
                 << o.straightness << ", " << o.min_length_mm << ", " << o.edge_min_length_mm
                 << ", " << o.even_calibre << ", " << o.field_edge_px);
  std::vector<bool> out(graph.branches.size(), false);
  for (std::size_t k = 0; k < graph.branches.size(); ++k) {
    const Branch2d& chain = graph.branches[k];
    if (chain.points.size() < 2) continue;
    const double length_px = detail::chain_length_px(chain);
    const double length_mm = length_px / px_per_mm;
    const double chord = (chain.points.back() - chain.points.front()).norm();
    const bool straight_long =
        o.min_length_mm > 0 && length_mm >= o.min_length_mm && chord >= o.straightness * length_px;
    bool leaves = false;
    if (o.field_edge_px > 0 && length_mm >= o.edge_min_length_mm &&
        detail::radius_variation(chain) <= o.even_calibre)
      for (const std::size_t end : {std::size_t{0}, chain.points.size() - 1}) {
        // Thinning pulls a chain's end about its radius back from where the tube is cut.
        const int reach = o.field_edge_px + static_cast<int>(std::ceil(chain.radius_px[end]));
        leaves = leaves || detail::distance_to_field_edge(chain.points[end], graph.rows, graph.cols,
                                                          field, reach + 1) <= reach;
      }
    out[k] = straight_long || leaves;
  }
  return out;
}

/// Removes the catheter-like chains from `graph` (the others keep their order); returns how
/// many were removed.
inline std::size_t drop_catheter_like_chains(CenterlineGraph2d& graph, double px_per_mm,
                                             const Image<std::uint8_t>* field,
                                             const CatheterCueOptions& o) {
  const std::vector<bool> catheter = catheter_like_chains(graph, px_per_mm, field, o);
  std::vector<Branch2d> kept;
  kept.reserve(graph.branches.size());
  for (std::size_t k = 0; k < graph.branches.size(); ++k)
    if (!catheter[k]) kept.push_back(std::move(graph.branches[k]));
  const std::size_t dropped = graph.branches.size() - kept.size();
  graph.branches = std::move(kept);
  return dropped;
}

}  // namespace gimm
