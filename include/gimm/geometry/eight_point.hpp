#pragma once
/// The paper's weighted normalised 8-point algorithm for the fundamental matrix (x_b^T F x_a = 0),
/// apart from fundamental.hpp's affine solver and RANSAC: the epipolar gate (gating.hpp) needs
/// it alone. Bad and degenerate input as in fundamental.hpp's file comment: invalid values throw
/// naming the argument; a degenerate configuration returns std::nullopt.
#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <Eigen/SVD>
#include <cmath>
#include <limits>
#include <optional>

#include "gimm/core/error.hpp"
#include "gimm/geometry/correspondences.hpp"
#include "gimm/geometry/epipolar.hpp"  // Matrix3

namespace gimm {

namespace detail {

/// The paper's normalisation: weighted centroid mu, weighted mean distance d to it,
/// s = sqrt(2) / d, T = [[s, 0, -s mu_x], [0, s, -s mu_y], [0, 0, 1]].
/// Returns nullopt when all weighted points coincide (d = 0).
/// T for centroid mu and mean distance d; nullopt when d is 0 (all points coincide).
template <class Scalar>
std::optional<Matrix3<Scalar>> normalization_from(const Eigen::Matrix<Scalar, 2, 1>& mu, Scalar d) {
  if (!(d > std::numeric_limits<Scalar>::epsilon() * (Scalar(1) + mu.norm()))) return std::nullopt;
  const Scalar s = std::sqrt(Scalar(2)) / d;
  Matrix3<Scalar> T;
  T << s, 0, -s * mu.x(),  //
      0, s, -s * mu.y(),   //
      0, 0, 1;
  return T;
}

template <class Scalar>
std::optional<Matrix3<Scalar>> weighted_normalization(const Points2<Scalar>& x,
                                                      const VectorX<Scalar>& w) {
  const Scalar total = w.sum();
  const Eigen::Matrix<Scalar, 2, 1> mu = (x * w) / total;
  const Scalar d = ((x.colwise() - mu).colwise().norm() * w)(0) / total;
  return normalization_from(mu, d);
}

/// weighted_normalization with every weight 1, for 8 points, without its temporaries (RANSAC
/// calls it for every sample).
template <class Scalar>
std::optional<Matrix3<Scalar>> normalization_of_8(const Points2<Scalar>& x) {
  Eigen::Matrix<Scalar, 2, 1> mu = Eigen::Matrix<Scalar, 2, 1>::Zero();
  for (int i = 0; i < 8; ++i) mu += x.col(i);
  mu /= Scalar(8);
  Scalar d = 0;
  for (int i = 0; i < 8; ++i) d += (x.col(i) - mu).norm();
  d /= Scalar(8);
  return normalization_from(mu, d);
}

/// Smallest eigenvector of a symmetric PSD matrix, or nullopt when the smallest eigenvalue is
/// not isolated (second-smallest below `rel_tol` times the largest): the solution is not unique.
template <class Scalar, int N>
std::optional<Eigen::Matrix<Scalar, N, 1>> unique_null_vector(const Eigen::Matrix<Scalar, N, N>& M,
                                                              Scalar rel_tol) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<Scalar, N, N>> eig(M);
  if (eig.info() != Eigen::Success) return std::nullopt;
  const auto& lambda = eig.eigenvalues();  // ascending
  if (!(lambda(N - 1) > 0) || !(lambda(1) > rel_tol * lambda(N - 1))) return std::nullopt;
  return eig.eigenvectors().col(0);
}

template <class Scalar>
Matrix3<Scalar> enforce_rank2(const Matrix3<Scalar>& F) {
  Eigen::JacobiSVD<Matrix3<Scalar>> svd(F, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix<Scalar, 3, 1> sigma = svd.singularValues();
  sigma(2) = 0;
  return svd.matrixU() * sigma.asDiagonal() * svd.matrixV().transpose();
}

/// Tolerance on the eigenvalue ratio for "unique solution": eigenvalues are squared singular
/// values, so 1e3 eps ~ a singular-value ratio of sqrt(1e3 eps) (5e-7 in double).
template <class Scalar>
Scalar uniqueness_tolerance() {
  return Scalar(1000) * std::numeric_limits<Scalar>::epsilon();
}

/// The row a_i of the 8-point system for one pair of normalised points (x = x_a, x' = x_b),
/// scaled by r: [x'x, x'y, x', y'x, y'y, y', x, y, 1] r.
template <class Scalar>
Eigen::Matrix<Scalar, 9, 1> eight_point_row(const Matrix3<Scalar>& Ta, const Matrix3<Scalar>& Tb,
                                            const Eigen::Matrix<Scalar, 2, 1>& a,
                                            const Eigen::Matrix<Scalar, 2, 1>& b, Scalar r) {
  const Scalar xa = Ta(0, 0) * a.x() + Ta(0, 2), ya = Ta(0, 0) * a.y() + Ta(1, 2);
  const Scalar xb = Tb(0, 0) * b.x() + Tb(0, 2), yb = Tb(0, 0) * b.y() + Tb(1, 2);
  Eigen::Matrix<Scalar, 9, 1> row;
  row << r * xb * xa, r * xb * ya, r * xb, r * yb * xa, r * yb * ya, r * yb, r * xa, r * ya, r;
  return row;
}

/// The rank-2 matrix nearest F as enforce_rank2 finds it, F (I - v v^T) with v the eigenvector
/// of F^T F of least eigenvalue (F's right singular vector of least singular value), at a
/// third of the SVD's cost: for RANSAC's hypotheses.
template <class Scalar>
Matrix3<Scalar> enforce_rank2_fast(const Matrix3<Scalar>& F) {
  const Eigen::SelfAdjointEigenSolver<Matrix3<Scalar>> eig(F.transpose() * F);
  const Eigen::Matrix<Scalar, 3, 1> v = eig.eigenvectors().col(0);  // ascending eigenvalues
  return F - (F * v) * v.transpose();
}

/// F from the null vector f (row-major) of the normalised system: rank 2 enforced (by SVD, or
/// by enforce_rank2_fast when `fast`), denormalised, scaled to unit norm; nullopt when that
/// fails.
template <class Scalar>
std::optional<Matrix3<Scalar>> fundamental_from_null_vector(const Eigen::Matrix<Scalar, 9, 1>& f,
                                                            const Matrix3<Scalar>& Ta,
                                                            const Matrix3<Scalar>& Tb,
                                                            bool fast = false) {
  const Eigen::Map<const Eigen::Matrix<Scalar, 3, 3, Eigen::RowMajor>> F_full(f.data());
  const Matrix3<Scalar> F_normalised =
      fast ? enforce_rank2_fast<Scalar>(F_full) : enforce_rank2<Scalar>(F_full);
  const Matrix3<Scalar> F = Tb.transpose() * F_normalised * Ta;
  if (!F.allFinite() || !(F.norm() > 0)) return std::nullopt;
  return normalize_fundamental(F);
}

}  // namespace detail

/// The paper's weighted normalised 8-point algorithm (gimm-paper.tex, Sec. "Epipolar Geometry
/// Module"): rows a_i = [x'x, x'y, x', y'x, y'y, y', x, y, 1] on normalised points (x = x_a,
/// x' = x_b), minimise ||W A f||^2 with W = diag(sqrt(w_i)) (the eigenvector of A^T W^2 A with
/// the smallest eigenvalue), enforce rank 2 by SVD, denormalise F = T_b^T F~ T_a.
/// f is F in row-major order, which is what the rows a_i pair with (the paper's "column-wise"
/// wording notwithstanding).
/// x_a, x_b: (2, N) pixels; weights: (N) >= 0, or empty for all ones.
/// Returns the normalised F, or nullopt for a degenerate configuration (see the file comment).
template <class Scalar>
std::optional<Matrix3<Scalar>> fundamental_8pt(const Points2<Scalar>& x_a,
                                               const Points2<Scalar>& x_b,
                                               const VectorX<Scalar>& weights) {
  const bool weighted = weights.size() > 0;
  const Eigen::Index n = x_a.cols();
  const Eigen::Index positive = detail::check_correspondences<Scalar>(
      "fundamental_8pt", x_a, x_b, weighted ? &weights : nullptr, 8);
  if (positive < 8) return std::nullopt;
  const VectorX<Scalar> w = weighted ? weights : VectorX<Scalar>::Ones(n);

  const auto Ta = detail::weighted_normalization<Scalar>(x_a, w);
  const auto Tb = detail::weighted_normalization<Scalar>(x_b, w);
  if (!Ta || !Tb) return std::nullopt;

  // Rows sqrt(w_i) a_i; M = A^T W^2 A accumulated as one (9, N) x (N, 9) product.
  Eigen::Matrix<Scalar, 9, Eigen::Dynamic> At(9, n);
  for (Eigen::Index i = 0; i < n; ++i)
    At.col(i) = detail::eight_point_row<Scalar>(*Ta, *Tb, x_a.col(i), x_b.col(i), std::sqrt(w(i)));
  Eigen::Matrix<Scalar, 9, 9> M = Eigen::Matrix<Scalar, 9, 9>::Zero();
  M.template selfadjointView<Eigen::Lower>().rankUpdate(At);
  M = M.template selfadjointView<Eigen::Lower>();
  const auto f = detail::unique_null_vector<Scalar, 9>(M, detail::uniqueness_tolerance<Scalar>());
  if (!f) return std::nullopt;
  return detail::fundamental_from_null_vector<Scalar>(*f, *Ta, *Tb);
}

/// The 8-point on exactly 8 correspondences, RANSAC's minimal samples: the 8 x 9 system's null
/// vector is then exact and unique (or the sample is degenerate), so it is found by LU with full
/// pivoting instead of the 9 x 9 eigensolver, and rank 2 is enforced without an SVD, several
/// times faster (docs/performance.md); the F
/// is fundamental_8pt's on the same points to rounding (tested). No argument checks beyond the
/// count: RANSAC checked the points once.
template <class Scalar>
std::optional<Matrix3<Scalar>> fundamental_8pt_minimal(const Points2<Scalar>& x_a,
                                                       const Points2<Scalar>& x_b) {
  GIMM_CHECK(x_a.cols() == 8 && x_b.cols() == 8,
             "fundamental_8pt_minimal: needs exactly 8 correspondences, got "
                 << x_a.cols() << " and " << x_b.cols());
  const auto Ta = detail::normalization_of_8<Scalar>(x_a);
  const auto Tb = detail::normalization_of_8<Scalar>(x_b);
  if (!Ta || !Tb) return std::nullopt;
  Eigen::Matrix<Scalar, 8, 9> A;
  for (int i = 0; i < 8; ++i)
    A.row(i) =
        detail::eight_point_row<Scalar>(*Ta, *Tb, x_a.col(i), x_b.col(i), Scalar(1)).transpose();
  const Scalar tolerance = std::sqrt(detail::uniqueness_tolerance<Scalar>());
  Eigen::Matrix<Scalar, 9, 1> f;
  // Usually F~(2, 2) != 0: f = (g, 1) with the first 8 columns times g = -(the last), by LU with
  // partial pivoting. A pivot near 0 (F~(2, 2) ~ 0, or a degenerate sample) takes full pivoting,
  // which finds the null vector wherever it lies, or the rank below 8.
  const Eigen::PartialPivLU<Eigen::Matrix<Scalar, 8, 8>> partial(A.template leftCols<8>());
  const auto pivots = partial.matrixLU().diagonal().cwiseAbs();
  if (pivots.minCoeff() > tolerance * pivots.maxCoeff()) {
    f << partial.solve(-A.col(8)), Scalar(1);
  } else {
    Eigen::FullPivLU<Eigen::Matrix<Scalar, 8, 9>> full(A);
    full.setThreshold(tolerance);
    if (full.rank() < 8) return std::nullopt;  // a degenerate sample: no unique solution
    f = full.kernel().col(0);
  }
  if (!f.allFinite()) return std::nullopt;
  return detail::fundamental_from_null_vector<Scalar>(f.normalized(), *Ta, *Tb, true);
}

/// The unweighted 8-point (every weight 1).
template <class Scalar>
std::optional<Matrix3<Scalar>> fundamental_8pt(const Points2<Scalar>& x_a,
                                               const Points2<Scalar>& x_b) {
  return fundamental_8pt<Scalar>(x_a, x_b, VectorX<Scalar>());
}

// The double instance is costly to compile (a 9x9 eigensolver): gimm's own binaries compile it
// once (src/instances/eight_point.cpp) and see it as extern here; consumers do not define
// GIMM_EXTERN_INSTANCES and instantiate it as usual.
#define GIMM_EIGHT_POINT_INSTANCES(EXTERN)                                        \
  EXTERN template std::optional<Matrix3<double>> fundamental_8pt<double>(         \
      const Points2<double>&, const Points2<double>&, const VectorX<double>&);    \
  EXTERN template std::optional<Matrix3<double>> fundamental_8pt_minimal<double>( \
      const Points2<double>&, const Points2<double>&);
#ifdef GIMM_EXTERN_INSTANCES
GIMM_EIGHT_POINT_INSTANCES(extern)
#endif

}  // namespace gimm
