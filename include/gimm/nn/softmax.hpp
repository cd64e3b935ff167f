#pragma once
/// Softmax over rows, the dual softmax of coarse matching, and the soft-argmax (expectation)
/// of fine matching.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/core/parallel.hpp"
#include "gimm/nn/fast_exp.hpp"
#include "gimm/nn/tensor.hpp"

namespace gimm::nn {

/// Softmax of each row of a [rows, cols] buffer, max-subtracted for stability.
inline void softmax_rows_inplace(float* x, std::int64_t rows, std::int64_t cols) {
  GIMM_CHECK(rows >= 0 && cols > 0,
             "softmax: needs at least one column, got " << rows << " x " << cols);
  for (std::int64_t r = 0; r < rows; ++r) {
    float* v = x + r * cols;
    const float top = *std::max_element(v, v + cols);
    float sum = 0.0f;
    for (std::int64_t i = 0; i < cols; ++i) sum += (v[i] = std::exp(v[i] - top));
    const float inv = 1.0f / sum;
    for (std::int64_t i = 0; i < cols; ++i) v[i] *= inv;
  }
}

/// Runs body(j0, j1) over blocks of 256 contiguous columns in parallel: column reductions of a
/// row-major matrix that read each row's slice, without a transposed copy.
template <class Body>
void parallel_column_blocks(std::int64_t cols, Body&& body) {
  constexpr std::int64_t kBlock = 256;
  parallel_for(0, (cols + kBlock - 1) / kBlock, [&](std::int64_t block) {
    body(block * kBlock, std::min(cols, block * kBlock + kBlock));
  });
}

/// Maximum of every column of a row-major [rows, cols] buffer.
inline std::vector<float> column_maxima(const float* x, std::int64_t rows, std::int64_t cols) {
  std::vector<float> top(static_cast<std::size_t>(cols), -INFINITY);
  parallel_column_blocks(cols, [&](std::int64_t j0, std::int64_t j1) {
    float* __restrict t = top.data() + j0;  // local, unaliased pointers: the loop vectorises
    for (std::int64_t i = 0; i < rows; ++i) {
      const float* __restrict row = x + i * cols + j0;
      for (std::int64_t j = 0; j < j1 - j0; ++j) t[j] = std::max(t[j], row[j]);
    }
  });
  return top;
}

/// Reference: conf = softmax over axis 0 (columns) times softmax over axis 1 (rows), each
/// computed on its own copy.
inline Tensor dual_softmax_reference(const Tensor& sim) {
  sim.expect_rank(2, "dual_softmax");
  const std::int64_t l = sim.dim(0), s = sim.dim(1);
  Tensor rows = sim, cols({s, l});
  for (std::int64_t i = 0; i < l; ++i)
    for (std::int64_t j = 0; j < s; ++j) cols[j * l + i] = sim[i * s + j];
  softmax_rows_inplace(rows.data(), l, s);
  softmax_rows_inplace(cols.data(), s, l);
  for (std::int64_t i = 0; i < l; ++i)
    for (std::int64_t j = 0; j < s; ++j) rows[i * s + j] *= cols[j * l + i];
  return rows;
}

/// Fast path, in place and without a transposed copy: sim / temperature, then row and column
/// max and exp-sums (rows in parallel, columns in parallel blocks of contiguous columns), then
/// conf = exp(s - rmax) / rsum * exp(s - cmax) / csum in a last parallel sweep, with the
/// vectorised fast_exp (the reference uses std::exp).
inline void dual_softmax_inplace(Tensor& sim, float temperature = 1.0f) {
  sim.expect_rank(2, "dual_softmax");
  GIMM_CHECK(temperature > 0, "dual_softmax: temperature must be > 0, got " << temperature);
  const std::int64_t l = sim.dim(0), s = sim.dim(1);
  GIMM_CHECK(l > 0 && s > 0, "dual_softmax: empty matrix " << shape_string(sim.shape()));
  std::vector<float> rmax(static_cast<std::size_t>(l)), rinv(static_cast<std::size_t>(l));
  std::vector<float> cinv(static_cast<std::size_t>(s), 0.0f);
  float* x = sim.data();
  parallel_for(
      0, l,
      [&](std::int64_t i) {
        float* v = x + i * s;
        for (std::int64_t j = 0; j < s; ++j) v[j] /= temperature;
        const float top = *std::max_element(v, v + s);
        float sum = 0.0f;
        for (std::int64_t j = 0; j < s; ++j) sum += fast_exp(v[j] - top);
        rmax[static_cast<std::size_t>(i)] = top;
        rinv[static_cast<std::size_t>(i)] = 1.0f / sum;
      },
      64);
  const std::vector<float> cmax = column_maxima(x, l, s);
  parallel_column_blocks(s, [&](std::int64_t j0, std::int64_t j1) {
    const float* __restrict top = cmax.data() + j0;
    float* __restrict sum = cinv.data() + j0;
    for (std::int64_t i = 0; i < l; ++i) {
      const float* __restrict row = x + i * s + j0;
      for (std::int64_t j = 0; j < j1 - j0; ++j) sum[j] += fast_exp(row[j] - top[j]);
    }
    for (std::int64_t j = 0; j < j1 - j0; ++j) sum[j] = 1.0f / sum[j];
  });
  // exp(v - rmax) exp(v - cmax) as one exp(2v - rmax - cmax): the product of the two softmaxes.
  const float* col_top = cmax.data();
  const float* col_inv = cinv.data();
  parallel_for(
      0, l,
      [&](std::int64_t i) {
        float* v = x + i * s;
        const float rm = rmax[static_cast<std::size_t>(i)], ri = rinv[static_cast<std::size_t>(i)];
        for (std::int64_t j = 0; j < s; ++j)
          v[j] = fast_exp((v[j] - rm) + (v[j] - col_top[j])) * (ri * col_inv[j]);
      },
      64);
}

/// Expectation of a window x window heat map (a softmax, rows sum to 1) over the grid
/// linspace(-1, 1, window) in x and y (kornia's spatial_expectation2d, normalised).
struct Expectation {
  float x = 0, y = 0;  ///< in [-1, 1]
  float std = 0;       ///< sqrt(var_x + var_y), a spread of the heat map
};

inline Expectation soft_argmax(const float* heat, int window) {
  GIMM_CHECK(window >= 1, "soft_argmax: window must be >= 1, got " << window);
  Expectation e;
  float xx = 0, yy = 0;
  for (int r = 0; r < window; ++r)
    for (int c = 0; c < window; ++c) {
      const float gx = window == 1 ? 0.0f : -1.0f + 2.0f * float(c) / float(window - 1);
      const float gy = window == 1 ? 0.0f : -1.0f + 2.0f * float(r) / float(window - 1);
      const float w = heat[r * window + c];
      e.x += w * gx;
      e.y += w * gy;
      xx += w * gx * gx;
      yy += w * gy * gy;
    }
  e.std = std::sqrt(std::max(xx - e.x * e.x + yy - e.y * e.y, 1e-10f));
  return e;
}

}  // namespace gimm::nn
