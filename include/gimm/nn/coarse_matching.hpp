#pragma once
/// Coarse match selection on a dual-softmax confidence matrix [L0, L1]: keep (i, j) when
/// conf(i, j) > threshold, both cells are inside the border, and conf(i, j) is the maximum of
/// its row and of its column (mutual nearest neighbours). Matches come in row-major order, as
/// torch.nonzero returns them. mutual_matches_reference is the plain double loop;
/// mutual_matches computes the row and column maxima in parallel.
#include <algorithm>
#include <cstdint>
#include <vector>

#include "gimm/core/parallel.hpp"
#include "gimm/nn/softmax.hpp"
#include "gimm/nn/tensor.hpp"

namespace gimm::nn {

struct CoarseMatches {
  std::vector<std::int64_t> i_ids, j_ids;
  std::vector<float> confidence;
};

/// 1 for the cells of a rows x cols grid at least `border` cells from every edge.
inline std::vector<char> inside_border(std::int64_t rows, std::int64_t cols, std::int64_t border) {
  std::vector<char> keep(static_cast<std::size_t>(rows * cols), 0);
  for (std::int64_t r = border; r < rows - border; ++r)
    for (std::int64_t c = border; c < cols - border; ++c)
      keep[static_cast<std::size_t>(r * cols + c)] = 1;
  return keep;
}

namespace detail {
inline void check_match_inputs(const Tensor& conf, const std::vector<char>& keep0,
                               const std::vector<char>& keep1) {
  conf.expect_rank(2, "coarse confidence");
  GIMM_CHECK(std::int64_t(keep0.size()) == conf.dim(0) && std::int64_t(keep1.size()) == conf.dim(1),
             "mutual_matches: border masks of " << keep0.size() << " and " << keep1.size()
                                                << " cells for a " << shape_string(conf.shape())
                                                << " matrix");
}
}  // namespace detail

inline CoarseMatches mutual_matches_reference(const Tensor& conf, float threshold,
                                              const std::vector<char>& keep0,
                                              const std::vector<char>& keep1) {
  detail::check_match_inputs(conf, keep0, keep1);
  const std::int64_t l = conf.dim(0), s = conf.dim(1);
  CoarseMatches out;
  for (std::int64_t i = 0; i < l; ++i)
    for (std::int64_t j = 0; j < s; ++j) {
      const float v = conf.at(i, j);
      if (!(v > threshold) || !keep0[std::size_t(i)] || !keep1[std::size_t(j)]) continue;
      bool best = true;
      for (std::int64_t k = 0; k < s && best; ++k) best = conf.at(i, k) <= v;
      for (std::int64_t k = 0; k < l && best; ++k) best = conf.at(k, j) <= v;
      if (!best) continue;
      out.i_ids.push_back(i);
      out.j_ids.push_back(j);
      out.confidence.push_back(v);
    }
  return out;
}

inline CoarseMatches mutual_matches(const Tensor& conf, float threshold,
                                    const std::vector<char>& keep0,
                                    const std::vector<char>& keep1) {
  detail::check_match_inputs(conf, keep0, keep1);
  const std::int64_t l = conf.dim(0), s = conf.dim(1);
  const float* x = conf.data();
  const std::vector<float> col_max = column_maxima(x, l, s);
  // Per row, the columns that qualify (a row can hold several only on exact ties).
  std::vector<std::vector<std::int64_t>> per_row(static_cast<std::size_t>(l));
  parallel_for(
      0, l,
      [&](std::int64_t i) {
        if (!keep0[std::size_t(i)]) return;
        const float* row = x + i * s;
        const float row_max = *std::max_element(row, row + s);
        if (!(row_max > threshold)) return;
        for (std::int64_t j = 0; j < s; ++j)
          if (row[j] == row_max && row[j] == col_max[std::size_t(j)] && keep1[std::size_t(j)])
            per_row[std::size_t(i)].push_back(j);
      },
      64);
  CoarseMatches out;
  for (std::int64_t i = 0; i < l; ++i)
    for (std::int64_t j : per_row[std::size_t(i)]) {
      out.i_ids.push_back(i);
      out.j_ids.push_back(j);
      out.confidence.push_back(x[i * s + j]);
    }
  return out;
}

}  // namespace gimm::nn
