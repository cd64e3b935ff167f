#pragma once
/// Epipolar gating of match confidences (gimm-paper.tex, "Epipolar Geometry Module").
///
/// Given matches x_a[i] <-> x_b[i] with confidence c_i and a fundamental matrix F, let
/// d2_i = squared symmetric epipolar distance (px^2, see epipolar.hpp). Then
///   hard:  keep match i iff d2_i <= delta^2; its confidence is unchanged, dropped ones get 0;
///   soft:  c_i * exp(-d2_i / tau^2)        (every match kept);
///   logit: c_i * sigmoid(-d2_i / tau^2)    (every match kept; note sigmoid(0) = 1/2, so even a
///          perfect match loses half its confidence: ranking is what this gate changes);
///   none:  unchanged.
/// These are exactly the reference code's semantics (reference-notes.md), with the paper's
/// defaults tau = 2.0 and delta = 2.0 px.
///
/// Where F comes from:
///   - gate_with_fundamental: a given F, e.g. the exact F of two known C-arm cameras (what the
///     reference leaves unused);
///   - gate_reference: F estimated from the matches themselves as the reference does: the
///     weighted 8-point (weights = confidence) on the `top_k` most confident matches (ties by
///     index), and no gating at all when there are fewer than `min_matches` matches or the
///     estimate is degenerate.
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <optional>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/geometry/correspondences.hpp"
#include "gimm/geometry/eight_point.hpp"
#include "gimm/geometry/epipolar.hpp"
#include "gimm/geometry/gate_options.hpp"

namespace gimm {

template <class Scalar>
struct GateResult {
  VectorX<Scalar> confidence;  ///< (N) gated confidences
  std::vector<char> keep;      ///< (N) 0 where the hard gate dropped the match
  VectorX<Scalar>
      distance_sq;  ///< (N) squared symmetric epipolar distance, px^2 (empty if ungated)
  std::optional<Matrix3<Scalar>> F;  ///< the F used, nullopt if no gating happened
};

/// The gate factor for one squared distance.
inline double gate_factor(GateMode mode, double d2, const GateOptions& options) {
  const double tau2 = options.tau * options.tau;
  switch (mode) {
    case GateMode::none:
      return 1.0;
    case GateMode::hard:
      return d2 <= options.delta_px * options.delta_px ? 1.0 : 0.0;
    case GateMode::soft:
      return std::exp(-d2 / tau2);
    case GateMode::logit:
      return 1.0 / (1.0 + std::exp(d2 / tau2));
  }
  return 1.0;
}

/// Gates confidences with a given F (x_b^T F x_a = 0). x_a, x_b: (2, N); confidence: (N).
template <class Scalar>
GateResult<Scalar> gate_with_fundamental(const Matrix3<Scalar>& F, const Points2<Scalar>& x_a,
                                         const Points2<Scalar>& x_b,
                                         const VectorX<Scalar>& confidence,
                                         const GateOptions& options = {}) {
  options.validate();
  detail::check_correspondences<Scalar>("gate_with_fundamental", x_a, x_b, &confidence, 0);
  GIMM_CHECK(F.allFinite(), "gate_with_fundamental: F has non-finite entries");
  GateResult<Scalar> out;
  const Eigen::Index n = x_a.cols();
  out.confidence = confidence;
  out.keep.assign(static_cast<std::size_t>(n), 1);
  out.distance_sq.resize(n);
  out.F = F;
  for (Eigen::Index i = 0; i < n; ++i) {
    const Scalar d2 = symmetric_epipolar_distance_sq<Scalar>(F, x_a.col(i), x_b.col(i));
    out.distance_sq(i) = d2;
    const double factor = gate_factor(options.mode, static_cast<double>(d2), options);
    out.confidence(i) = static_cast<Scalar>(confidence(i) * factor);
    if (options.mode == GateMode::hard && factor == 0.0) out.keep[static_cast<std::size_t>(i)] = 0;
  }
  return out;
}

/// Indices of the k largest confidences, descending; ties keep the lower index first.
template <class Scalar>
std::vector<Eigen::Index> top_k_by_confidence(const VectorX<Scalar>& confidence, Eigen::Index k) {
  std::vector<Eigen::Index> idx(static_cast<std::size_t>(confidence.size()));
  std::iota(idx.begin(), idx.end(), Eigen::Index{0});
  k = std::min<Eigen::Index>(k, confidence.size());
  std::partial_sort(idx.begin(), idx.begin() + k, idx.end(), [&](Eigen::Index a, Eigen::Index b) {
    return confidence(a) > confidence(b) || (confidence(a) == confidence(b) && a < b);
  });
  idx.resize(static_cast<std::size_t>(k));
  return idx;
}

/// F estimated from the matches as the reference does (see the file comment), or nullopt.
template <class Scalar>
std::optional<Matrix3<Scalar>> fundamental_from_matches(const Points2<Scalar>& x_a,
                                                        const Points2<Scalar>& x_b,
                                                        const VectorX<Scalar>& confidence,
                                                        const GateOptions& options = {}) {
  options.validate();
  detail::check_correspondences<Scalar>("fundamental_from_matches", x_a, x_b, &confidence, 0);
  if (x_a.cols() < options.min_matches) return std::nullopt;
  const auto idx = top_k_by_confidence<Scalar>(confidence, options.top_k);
  Points2<Scalar> a(2, idx.size()), b(2, idx.size());
  VectorX<Scalar> w(static_cast<Eigen::Index>(idx.size()));
  for (std::size_t k = 0; k < idx.size(); ++k) {
    a.col(k) = x_a.col(idx[k]);
    b.col(k) = x_b.col(idx[k]);
    w(k) = confidence(idx[k]);
  }
  return fundamental_8pt<Scalar>(a, b, w);
}

/// The reference's gating: F from the matches, then gate; ungated (unchanged) when no F.
template <class Scalar>
GateResult<Scalar> gate_reference(const Points2<Scalar>& x_a, const Points2<Scalar>& x_b,
                                  const VectorX<Scalar>& confidence,
                                  const GateOptions& options = {}) {
  const auto F = fundamental_from_matches<Scalar>(x_a, x_b, confidence, options);
  if (!F || options.mode == GateMode::none) {
    GateResult<Scalar> out;
    out.confidence = confidence;
    out.keep.assign(static_cast<std::size_t>(confidence.size()), 1);
    return out;
  }
  return gate_with_fundamental<Scalar>(*F, x_a, x_b, confidence, options);
}

// The double instantiations above are the costly ones to compile (Eigen decompositions):
// gimm's own binaries compile them once (src/instances/) and see them as extern here.
// Consumers do not define GIMM_EXTERN_INSTANCES and instantiate them as usual.
#define GIMM_GATING_INSTANCES(EXTERN)                                                              \
  EXTERN template std::optional<Matrix3<double>> fundamental_from_matches<double>(                 \
      const Points2<double>&, const Points2<double>&, const VectorX<double>&, const GateOptions&); \
  EXTERN template GateResult<double> gate_reference<double>(                                       \
      const Points2<double>&, const Points2<double>&, const VectorX<double>&, const GateOptions&);
#ifdef GIMM_EXTERN_INSTANCES
GIMM_GATING_INSTANCES(extern)
#endif

}  // namespace gimm
