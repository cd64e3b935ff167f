#pragma once
/// Fundamental-matrix estimation from point correspondences x_a[i] <-> x_b[i] (pixels),
/// with the convention x_b^T F x_a = 0.
///
/// - fundamental_8pt: the paper's weighted normalised 8-point (Hartley 1997; Yi et al. 2018),
///   in eight_point.hpp (the gate needs it alone). Unweighted = all weights 1.
/// - fundamental_affine: the affine F of two orthographic (parallel-beam) views, by the Gold
///   Standard orthogonal regression (Hartley & Zisserman, alg. 14.1), weighted.
/// - estimate_fundamental_ransac: MSAC with local optimisation around either solver.
///
/// Bad input vs degenerate input:
/// - Invalid values throw gimm::Error naming the argument: sizes that differ, too few
///   correspondences for the solver, non-finite coordinates, negative or non-finite weights.
/// - Geometrically degenerate configurations return std::nullopt (documented empty result):
///   fewer than the minimal number of correspondences with positive weight, all points of one
///   image coincident, or a solution that is not unique (collinear points, rank-deficient data).
#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <optional>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/core/rng.hpp"
#include "gimm/geometry/correspondences.hpp"
#include "gimm/geometry/eight_point.hpp"
#include "gimm/geometry/epipolar.hpp"

namespace gimm {

/// Affine fundamental matrix F = [[0, 0, a], [0, 0, b], [c, d, e]] of two orthographic views:
/// a x_b + b y_b + c x_a + d y_a + e = 0. Gold Standard: (a, b, c, d) is the direction of least
/// weighted variance of the 4D points (x_b, y_b, x_a, y_a) and e = -(a, b, c, d) . centroid,
/// which minimises the weighted sum of squared geometric distances. Needs >= 4 points.
/// Returns nullopt for degenerate configurations (fewer than 4 positive weights, solution not
/// unique, or a constraint that does not involve both images).
template <class Scalar>
std::optional<Matrix3<Scalar>> fundamental_affine(const Points2<Scalar>& x_a,
                                                  const Points2<Scalar>& x_b,
                                                  const VectorX<Scalar>& weights = {}) {
  const bool weighted = weights.size() > 0;
  const Eigen::Index n = x_a.cols();
  const Eigen::Index positive = detail::check_correspondences<Scalar>(
      "fundamental_affine", x_a, x_b, weighted ? &weights : nullptr, 4);
  if (positive < 4) return std::nullopt;
  const VectorX<Scalar> w = weighted ? weights : VectorX<Scalar>::Ones(n);

  Eigen::Matrix<Scalar, 4, Eigen::Dynamic> q(4, n);
  q << x_b, x_a;
  const Eigen::Matrix<Scalar, 4, 1> mu = q * w / w.sum();
  const Eigen::Matrix<Scalar, 4, Eigen::Dynamic> centred =
      (q.colwise() - mu) * w.cwiseSqrt().asDiagonal();
  const Eigen::Matrix<Scalar, 4, 4> cov = centred * centred.transpose();
  const auto nvec =
      detail::unique_null_vector<Scalar, 4>(cov, detail::uniqueness_tolerance<Scalar>());
  if (!nvec) return std::nullopt;
  const auto& v = *nvec;
  // A constraint on one image alone (all x_b on a line, say) is no epipolar geometry.
  const Scalar eps = Scalar(1e-9);
  if (std::hypot(v(0), v(1)) < eps || std::hypot(v(2), v(3)) < eps) return std::nullopt;
  Matrix3<Scalar> F = Matrix3<Scalar>::Zero();
  F(0, 2) = v(0);
  F(1, 2) = v(1);
  F(2, 0) = v(2);
  F(2, 1) = v(3);
  F(2, 2) = -v.dot(mu);
  return normalize_fundamental(F);
}

enum class FundamentalModel { perspective, affine };
enum class EpipolarDistance { sampson, symmetric };

/// Options of estimate_fundamental_ransac. Units: pixels.
/// The most iterations RANSAC accepts: 1e8 minimal samples take minutes, not years (a count of
/// 2^62 given by mistake hung the caller).
inline constexpr std::int64_t kMaxRansacIterations = 100000000;

struct RansacOptions {
  FundamentalModel model = FundamentalModel::perspective;  ///< 8-point or affine minimal solver
  EpipolarDistance distance = EpipolarDistance::sampson;   ///< residual used for inliers
  double threshold_px = 1.0;  ///< inlier if sqrt(distance_sq) <= threshold_px
  double confidence = 0.999;  ///< stop when P(all samples so far contaminated) < 1 - confidence
  std::int64_t max_iterations = 10000;
  std::int64_t min_iterations = 10;
  int local_optimization_steps = 3;  ///< refits on inliers after each new best (0 = plain MSAC)
  /// A local optimisation refits on at most this many of the inliers (a seeded sample, as
  /// LO-RANSAC's inner samples: Chum et al. 2003), 0 = all; the final refit takes them all.
  int local_optimization_sample = 64;
  std::uint64_t seed = 0;  ///< same seed, same result
};

struct RansacStats {
  std::int64_t iterations = 0;
  std::int64_t degenerate_samples = 0;
  std::int64_t local_optimizations = 0;
  std::int64_t num_inliers = 0;
  double inlier_ratio = 0.0;
  double score = std::numeric_limits<double>::infinity();  ///< MSAC cost (px^2), lower is better
};

template <class Scalar>
struct RansacResult {
  std::optional<Matrix3<Scalar>> F;  ///< nullopt if no non-degenerate model was found
  std::vector<char> inliers;         ///< (N) 1 for inliers of F
  RansacStats stats;
};

/// Robust F by MSAC (Torr & Zisserman 2000) with local optimisation (Chum et al. 2003): random
/// minimal samples (8 for perspective, 4 for affine), truncated-quadratic cost, and each new
/// best model refit on its inliers by the (unweighted) least-squares solver. The returned F is
/// the final refit on all inliers. Deterministic for a given seed.
template <class Scalar>
RansacResult<Scalar> estimate_fundamental_ransac(const Points2<Scalar>& x_a,
                                                 const Points2<Scalar>& x_b,
                                                 const RansacOptions& options = {}) {
  const bool affine = options.model == FundamentalModel::affine;
  const Eigen::Index minimal = affine ? 4 : 8;
  detail::check_correspondences<Scalar>("estimate_fundamental_ransac", x_a, x_b, nullptr, minimal);
  GIMM_CHECK(std::isfinite(options.threshold_px) && options.threshold_px > 0,
             "estimate_fundamental_ransac: threshold_px must be > 0, got " << options.threshold_px);
  GIMM_CHECK(
      options.confidence > 0 && options.confidence < 1,
      "estimate_fundamental_ransac: confidence must be in (0, 1), got " << options.confidence);
  GIMM_CHECK(options.local_optimization_steps >= 0 && options.local_optimization_sample >= 0,
             "estimate_fundamental_ransac: local_optimization_steps and local_optimization_sample "
             "must be >= 0, got "
                 << options.local_optimization_steps << " and "
                 << options.local_optimization_sample);
  GIMM_CHECK(options.max_iterations >= 1 && options.max_iterations <= kMaxRansacIterations &&
                 options.min_iterations >= 0 && options.min_iterations <= options.max_iterations,
             "estimate_fundamental_ransac: need 1 <= max_iterations <= "
                 << kMaxRansacIterations << " and 0 <= min_iterations <= max_iterations, got "
                 << options.min_iterations << " and " << options.max_iterations);

  const Eigen::Index n = x_a.cols();
  const double thr_sq = options.threshold_px * options.threshold_px;
  auto solve = [&](const Points2<Scalar>& a, const Points2<Scalar>& b) {
    return affine ? fundamental_affine<Scalar>(a, b) : fundamental_8pt<Scalar>(a, b);
  };
  auto solve_minimal = [&](const Points2<Scalar>& a, const Points2<Scalar>& b) {
    return affine ? fundamental_affine<Scalar>(a, b) : fundamental_8pt_minimal<Scalar>(a, b);
  };
  auto residual_sq = [&](const Matrix3<Scalar>& F, Eigen::Index i) -> double {
    const Eigen::Matrix<Scalar, 2, 1> a = x_a.col(i), b = x_b.col(i);
    return options.distance == EpipolarDistance::sampson
               ? static_cast<double>(sampson_distance_sq<Scalar>(F, a, b))
               : static_cast<double>(symmetric_epipolar_distance_sq<Scalar>(F, a, b));
  };
  // MSAC cost and inliers of F. The cost only grows, so scoring stops once it reaches `bound`
  // (the best score so far): such a model cannot win and its mask is never used. Same result
  // as scoring every point, in less time.
  auto score = [&](const Matrix3<Scalar>& F, std::vector<char>& mask, double bound) {
    double cost = 0;
    std::int64_t count = 0;
    for (Eigen::Index i = 0; i < n && cost < bound; ++i) {
      const double r = residual_sq(F, i);
      const bool inlier = r <= thr_sq;
      mask[static_cast<std::size_t>(i)] = inlier;
      count += inlier;
      cost += inlier ? r : thr_sq;
    }
    return std::make_pair(cost, count);
  };
  Rng lo_rng(options.seed ^ 0x10c41);
  // Least squares on the inliers of `mask`, on a seeded sample of at most `at_most` (0: all).
  auto refit = [&](const std::vector<char>& mask, int at_most) -> std::optional<Matrix3<Scalar>> {
    std::vector<Eigen::Index> idx;
    for (Eigen::Index i = 0; i < n; ++i)
      if (mask[static_cast<std::size_t>(i)]) idx.push_back(i);
    if (static_cast<Eigen::Index>(idx.size()) < minimal) return std::nullopt;
    if (at_most >= minimal && idx.size() > static_cast<std::size_t>(at_most)) {
      for (int k = 0; k < at_most; ++k)  // partial Fisher-Yates
        std::swap(idx[static_cast<std::size_t>(k)],
                  idx[k + lo_rng.below(static_cast<std::uint64_t>(idx.size() - k))]);
      idx.resize(static_cast<std::size_t>(at_most));
    }
    Points2<Scalar> a(2, idx.size()), b(2, idx.size());
    for (std::size_t k = 0; k < idx.size(); ++k) {
      a.col(k) = x_a.col(idx[k]);
      b.col(k) = x_b.col(idx[k]);
    }
    return solve(a, b);
  };

  RansacResult<Scalar> result;
  result.inliers.assign(static_cast<std::size_t>(n), 0);
  std::vector<char> mask(static_cast<std::size_t>(n), 0);
  std::vector<Eigen::Index> order(static_cast<std::size_t>(n));
  std::iota(order.begin(), order.end(), Eigen::Index{0});
  Points2<Scalar> sample_a(2, minimal), sample_b(2, minimal);
  Rng rng(options.seed);
  std::int64_t needed = options.max_iterations;

  auto consider = [&](const Matrix3<Scalar>& F) {
    const auto [cost, count] = score(F, mask, result.stats.score);
    if (cost >= result.stats.score) return false;
    result.F = F;
    result.inliers = mask;
    result.stats.score = cost;
    result.stats.num_inliers = count;
    return true;
  };

  for (std::int64_t it = 0; it < std::min(needed, options.max_iterations); ++it) {
    ++result.stats.iterations;
    for (Eigen::Index k = 0; k < minimal; ++k) {  // partial Fisher-Yates: distinct indices
      const auto j = k + static_cast<Eigen::Index>(rng.below(static_cast<std::uint64_t>(n - k)));
      std::swap(order[static_cast<std::size_t>(k)], order[static_cast<std::size_t>(j)]);
      sample_a.col(k) = x_a.col(order[static_cast<std::size_t>(k)]);
      sample_b.col(k) = x_b.col(order[static_cast<std::size_t>(k)]);
    }
    const auto F = solve_minimal(sample_a, sample_b);
    if (!F) {
      ++result.stats.degenerate_samples;
      continue;
    }
    if (!consider(*F)) continue;
    for (int step = 0; step < options.local_optimization_steps; ++step) {
      const auto refined = refit(result.inliers, options.local_optimization_sample);
      ++result.stats.local_optimizations;
      if (!refined || !consider(*refined)) break;
    }
    const double ratio = static_cast<double>(result.stats.num_inliers) / static_cast<double>(n);
    const double p_good_sample = std::pow(ratio, static_cast<double>(minimal));
    if (p_good_sample >= 1.0) {
      needed = options.min_iterations;
    } else if (p_good_sample > 0) {
      needed = std::max<std::int64_t>(
          options.min_iterations,
          static_cast<std::int64_t>(
              std::ceil(std::log(1 - options.confidence) / std::log1p(-p_good_sample))));
    }
  }
  if (result
          .F) {  // final least-squares refit on all inliers, kept only if it scores strictly better
    if (const auto refined = refit(result.inliers, 0)) consider(*refined);
  }
  result.stats.inlier_ratio =
      static_cast<double>(result.stats.num_inliers) / static_cast<double>(n);
  return result;
}

// The double instantiations above are the costly ones to compile (Eigen decompositions):
// gimm's own binaries compile them once (src/instances/) and see them as extern here.
// Consumers do not define GIMM_EXTERN_INSTANCES and instantiate them as usual.
#define GIMM_FUNDAMENTAL_INSTANCES(EXTERN)                                     \
  EXTERN template std::optional<Matrix3<double>> fundamental_affine<double>(   \
      const Points2<double>&, const Points2<double>&, const VectorX<double>&); \
  EXTERN template RansacResult<double> estimate_fundamental_ransac<double>(    \
      const Points2<double>&, const Points2<double>&, const RansacOptions&);
#ifdef GIMM_EXTERN_INSTANCES
GIMM_FUNDAMENTAL_INSTANCES(extern)
#endif

}  // namespace gimm
