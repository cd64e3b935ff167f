#pragma once
/// Grey-level morphology with square windows: running maxima and minima along rows and columns
/// (van Herk / Gil-Werman: three comparisons per pixel whatever the window's width), the closing
/// built from them, and the black top-hat that keeps the dark structures narrower than the
/// window. Windows are clipped to the image (for a maximum or a minimum the same as replicating
/// the edge pixel), so a closing is never below its input.
#include <algorithm>
#include <cstddef>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/core/image.hpp"

namespace gimm {
namespace detail {

/// out[i] = pick over line[i - half .. i + half] clipped to [0, n), for a contiguous line.
/// `pick` is a max or a min; `pad`, `ahead` and `behind` are scratch.
template <class Pick>
void running_extreme(const float* line, int n, int half, Pick pick, float* out,
                     std::vector<float>& pad, std::vector<float>& ahead,
                     std::vector<float>& behind) {
  const int width = 2 * half + 1;
  // The line padded by its edge values, in whole blocks of `width`: the window of output i is
  // pad[i .. i + width - 1], which spans at most two blocks.
  const int padded = (n + 2 * half + width - 1) / width * width;
  pad.resize(static_cast<std::size_t>(padded));
  ahead.resize(pad.size());
  behind.resize(pad.size());
  for (int j = 0; j < padded; ++j) pad[j] = line[std::clamp(j - half, 0, n - 1)];
  // ahead[j]: from j's block start to j; behind[j]: from j to its block end.
  for (int j = 0; j < padded; ++j) ahead[j] = j % width == 0 ? pad[j] : pick(ahead[j - 1], pad[j]);
  for (int j = padded - 1; j >= 0; --j)
    behind[j] = j % width == width - 1 ? pad[j] : pick(behind[j + 1], pad[j]);
  for (int i = 0; i < n; ++i) out[i] = pick(behind[i], ahead[i + width - 1]);
}

/// The square-window running extreme of an image: along each row, then along each column.
template <class Pick>
Image<float> square_extreme(const Image<float>& in, int width, Pick pick) {
  GIMM_CHECK(width >= 1 && width % 2 == 1,
             "morphology: the window width must be odd and >= 1 px, got " << width);
  const int rows = in.rows(), cols = in.cols(), half = width / 2;
  Image<float> out(rows, cols);
  std::vector<float> pad, ahead, behind, column(static_cast<std::size_t>(rows)),
      column_out(column.size());
  for (int r = 0; r < rows; ++r)
    running_extreme(&in(r, 0), cols, half, pick, &out(r, 0), pad, ahead, behind);
  for (int c = 0; c < cols; ++c) {  // columns through a contiguous copy
    for (int r = 0; r < rows; ++r) column[static_cast<std::size_t>(r)] = out(r, c);
    running_extreme(column.data(), rows, half, pick, column_out.data(), pad, ahead, behind);
    for (int r = 0; r < rows; ++r) out(r, c) = column_out[static_cast<std::size_t>(r)];
  }
  return out;
}

}  // namespace detail

/// Grey dilation (maximum) over a width x width window; width odd.
inline Image<float> grey_dilate(const Image<float>& in, int width) {
  return detail::square_extreme(in, width, [](float a, float b) { return std::max(a, b); });
}

/// Grey erosion (minimum) over a width x width window; width odd.
inline Image<float> grey_erode(const Image<float>& in, int width) {
  return detail::square_extreme(in, width, [](float a, float b) { return std::min(a, b); });
}

/// Black top-hat: closing (dilation, then erosion) minus the image, >= 0. A dark structure
/// narrower than `width` is filled by the closing and kept; wider ones and steps (edges) are not.
inline Image<float> black_top_hat(const Image<float>& in, int width) {
  Image<float> out = grey_erode(grey_dilate(in, width), width);
  for (std::size_t i = 0; i < out.size(); ++i) out.data()[i] -= in.data()[i];
  return out;
}

}  // namespace gimm
