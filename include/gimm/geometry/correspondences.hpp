#pragma once
/// Point correspondences x_a[i] <-> x_b[i] between two views (pixels) as the F estimation and
/// the gating take them: two (2, N) matrices and optional (N) weights, and their validation.
#include <Eigen/Core>
#include <cmath>

#include "gimm/core/error.hpp"

namespace gimm {

template <class Scalar>
using Points2 = Eigen::Matrix<Scalar, 2, Eigen::Dynamic>;
template <class Scalar>
using VectorX = Eigen::Matrix<Scalar, Eigen::Dynamic, 1>;

namespace detail {

/// Validates correspondences and weights; returns the number with positive weight.
template <class Scalar>
Eigen::Index check_correspondences(const char* who, const Points2<Scalar>& x_a,
                                   const Points2<Scalar>& x_b, const VectorX<Scalar>* weights,
                                   Eigen::Index minimal) {
  GIMM_CHECK(x_a.cols() == x_b.cols(),
             who << ": x_a has " << x_a.cols() << " points but x_b has " << x_b.cols());
  GIMM_CHECK(x_a.cols() >= minimal,
             who << ": need at least " << minimal << " correspondences, got " << x_a.cols());
  for (Eigen::Index i = 0; i < x_a.cols(); ++i)
    GIMM_CHECK(x_a.col(i).allFinite() && x_b.col(i).allFinite(),
               who << ": correspondence " << i << " has a non-finite coordinate (x_a = "
                   << x_a.col(i).transpose() << ", x_b = " << x_b.col(i).transpose() << ")");
  if (weights == nullptr) return x_a.cols();
  GIMM_CHECK(weights->size() == x_a.cols(),
             who << ": " << weights->size() << " weights for " << x_a.cols() << " points");
  Eigen::Index positive = 0;
  for (Eigen::Index i = 0; i < weights->size(); ++i) {
    const Scalar w = (*weights)(i);
    GIMM_CHECK(std::isfinite(w) && w >= 0,
               who << ": weight " << i << " must be finite and >= 0, got " << w);
    positive += w > 0;
  }
  return positive;
}

}  // namespace detail

}  // namespace gimm
