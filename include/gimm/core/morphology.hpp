#pragma once
/// Grey-level morphology with square windows: running maxima and minima along the rows and down
/// the columns (van Herk / Gil-Werman: three comparisons per pixel whatever the window's width),
/// the closing built from them, and the black top-hat that keeps the dark structures narrower
/// than the window. Windows are clipped to the image (for a maximum or a minimum the same as
/// replicating the edge pixel), so a closing is never below its input.
#include <algorithm>
#include <cstddef>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/core/image.hpp"

namespace gimm {
namespace detail {

/// out(i, c) = pick over in(i - half .. i + half, c), the window clipped to the rows. Whole rows
/// at a time, so the inner loops run along contiguous memory and vectorise.
template <class Pick>
void extreme_down_columns(const Image<float>& in, int half, Pick pick, Image<float>& out) {
  const int n = in.rows(), cols = in.cols(), width = 2 * half + 1;
  // Padded row j is input row j - half (clamped: the edge rows repeat). The window of output row
  // i is padded rows i .. i + width - 1. Blocks of `width` padded rows starting at b: for output
  // rows b .. b + width - 1, `behind` holds each row's extreme to the end of block b and `ahead`
  // each row's extreme from the start of block b + width, so a window is one pick of the two.
  const auto source = [&](int j) { return &in(std::clamp(j - half, 0, n - 1), 0); };
  std::vector<float> behind(static_cast<std::size_t>(width) * cols), ahead(behind.size());
  const auto row = [&](std::vector<float>& v, int k) { return v.data() + std::size_t(k) * cols; };
  const auto combine = [&](const float* x, const float* y, float* out) {
    for (int c = 0; c < cols; ++c) out[c] = pick(x[c], y[c]);
  };
  out.resize(n, cols);
  for (int b = 0; b < n; b += width) {
    std::copy(source(b + width - 1), source(b + width - 1) + cols, row(behind, width - 1));
    for (int k = width - 2; k >= 0; --k) combine(row(behind, k + 1), source(b + k), row(behind, k));
    std::copy(source(b + width), source(b + width) + cols, row(ahead, 0));
    for (int k = 1; k < width; ++k)
      combine(row(ahead, k - 1), source(b + width + k), row(ahead, k));
    std::copy(row(behind, 0), row(behind, 0) + cols, &out(b, 0));  // the window is block b
    for (int i = b + 1; i < std::min(b + width, n); ++i)
      combine(row(behind, i - b), row(ahead, i - b - 1), &out(i, 0));
  }
}

/// out[i] = pick over x[i - half .. i + half], clipped to [0, n): the blocks of
/// extreme_down_columns() along one row. `behind` and `ahead` hold 2 half + 1 values each.
template <class Pick>
void extreme_along_row(const float* x, int n, int half, Pick pick, float* out, float* behind,
                       float* ahead) {
  const int width = 2 * half + 1;
  const auto source = [&](int j) { return x[std::clamp(j - half, 0, n - 1)]; };
  for (int b = 0; b < n; b += width) {
    behind[width - 1] = source(b + width - 1);
    for (int k = width - 2; k >= 0; --k) behind[k] = pick(behind[k + 1], source(b + k));
    ahead[0] = source(b + width);
    for (int k = 1; k < width; ++k) ahead[k] = pick(ahead[k - 1], source(b + width + k));
    out[b] = behind[0];
    for (int i = b + 1; i < std::min(b + width, n); ++i)
      out[i] = pick(behind[i - b], ahead[i - b - 1]);
  }
}

/// The square-window running extreme of an image into `out`: along the rows (into `along`),
/// then down the columns. `along` and `out` are resized; `out` must not be `in`.
template <class Pick>
void square_extreme(const Image<float>& in, int width, Pick pick, Image<float>& along,
                    Image<float>& out) {
  GIMM_CHECK(width >= 1 && width % 2 == 1,
             "morphology: the window width must be odd and >= 1 px, got " << width);
  GIMM_CHECK(&in != &out && &in != &along,
             "morphology: the output and working images must not be the input");
  const int half = width / 2;
  along.resize(in.rows(), in.cols());
  std::vector<float> behind(static_cast<std::size_t>(width)), ahead(behind.size());
  for (int r = 0; r < in.rows(); ++r)
    extreme_along_row(&in(r, 0), in.cols(), half, pick, &along(r, 0), behind.data(), ahead.data());
  extreme_down_columns(along, half, pick, out);
}

template <class Pick>
Image<float> square_extreme(const Image<float>& in, int width, Pick pick) {
  Image<float> along, out;
  square_extreme(in, width, pick, along, out);
  return out;
}

// Function objects, not function pointers: the picks inline into the vectorised loops.
struct PickMax {
  float operator()(float a, float b) const { return std::max(a, b); }
};
struct PickMin {
  float operator()(float a, float b) const { return std::min(a, b); }
};

}  // namespace detail

/// Grey dilation (maximum) over a width x width window; width odd.
inline Image<float> grey_dilate(const Image<float>& in, int width) {
  return detail::square_extreme(in, width, detail::PickMax{});
}

/// Grey erosion (minimum) over a width x width window; width odd.
inline Image<float> grey_erode(const Image<float>& in, int width) {
  return detail::square_extreme(in, width, detail::PickMin{});
}

/// The working images of black_top_hat(), for a caller that keeps them between calls.
struct TopHatBuffers {
  Image<float> along, dilated;
};

/// Black top-hat into `out` (resized; not `in`): closing (dilation, then erosion) minus the
/// image, >= 0. A dark structure narrower than `width` is filled by the closing and kept; wider
/// ones and steps (edges) are not.
inline void black_top_hat(const Image<float>& in, int width, Image<float>& out,
                          TopHatBuffers& buffers) {
  GIMM_CHECK(&in != &out && &in != &buffers.along && &in != &buffers.dilated,
             "black_top_hat: the output and working images must not be the input");
  detail::square_extreme(in, width, detail::PickMax{}, buffers.along, buffers.dilated);
  detail::square_extreme(buffers.dilated, width, detail::PickMin{}, buffers.along, out);
  for (std::size_t i = 0; i < out.size(); ++i) out.data()[i] -= in.data()[i];
}

inline Image<float> black_top_hat(const Image<float>& in, int width) {
  Image<float> out;
  TopHatBuffers buffers;
  black_top_hat(in, width, out, buffers);
  return out;
}

}  // namespace gimm
