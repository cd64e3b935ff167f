#pragma once
/// gemm: C = A B (+ C) on row-major float buffers, through Eigen.
///
/// Eigen's product kernels are vectorised for the target ISA (build with -march=native to get
/// AVX2/AVX-512). gimm splits products across threads itself, in fixed row blocks: the target
/// gimm::gimm defines EIGEN_DONT_PARALLELIZE, because Eigen's own OpenMP split chooses its
/// depth blocking by thread count, so the last bits (and with them mutual-NN ties) would depend
/// on the number of threads. Every matrix is (pointer, rows, cols, leading dimension).
#include <Eigen/Core>
#include <algorithm>
#include <cstdint>

#include "gimm/core/parallel.hpp"

namespace gimm::nn {

using RowMatrix = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using MatrixMap = Eigen::Map<RowMatrix, 0, Eigen::OuterStride<>>;
using ConstMatrixMap = Eigen::Map<const RowMatrix, 0, Eigen::OuterStride<>>;

inline ConstMatrixMap matrix(const float* data, std::int64_t rows, std::int64_t cols,
                             std::int64_t ld) {
  return ConstMatrixMap(data, rows, cols, Eigen::OuterStride<>(ld));
}
inline MatrixMap matrix(float* data, std::int64_t rows, std::int64_t cols, std::int64_t ld) {
  return MatrixMap(data, rows, cols, Eigen::OuterStride<>(ld));
}

/// C[m x n] (=|+=) A[m x k] * B[k x n]; B may be given transposed (B^T stored as [n x k]).
inline void gemm(const float* a, std::int64_t lda, const float* b, std::int64_t ldb, float* c,
                 std::int64_t ldc, std::int64_t m, std::int64_t n, std::int64_t k,
                 bool b_transposed, bool accumulate) {
  auto out = matrix(c, m, n, ldc);
  auto lhs = matrix(a, m, k, lda);
  if (b_transposed) {
    auto rhs = matrix(b, n, k, ldb);
    if (accumulate)
      out.noalias() += lhs * rhs.transpose();
    else
      out.noalias() = lhs * rhs.transpose();
  } else {
    auto rhs = matrix(b, k, n, ldb);
    if (accumulate)
      out.noalias() += lhs * rhs;
    else
      out.noalias() = lhs * rhs;
  }
}

/// The same product, rows of C in blocks of 128 across threads (same result on any count).
inline void gemm_rows_parallel(const float* a, std::int64_t lda, const float* b, std::int64_t ldb,
                               float* c, std::int64_t ldc, std::int64_t m, std::int64_t n,
                               std::int64_t k, bool b_transposed) {
  constexpr std::int64_t kBlock = 128;
  parallel_for(0, (m + kBlock - 1) / kBlock, [&](std::int64_t block) {
    const std::int64_t r0 = block * kBlock, rows = std::min(kBlock, m - r0);
    gemm(a + r0 * lda, lda, b, ldb, c + r0 * ldc, ldc, rows, n, k, b_transposed, false);
  });
}

}  // namespace gimm::nn
