#pragma once
/// Separable image filters shared by the rooms: sampled Gaussian kernels (and their first and
/// second derivatives), float convolution passes along rows and along columns whose inner loops
/// run along contiguous memory (they vectorise), and the Gaussian blur built from them. Borders
/// replicate the edge pixel.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/core/image.hpp"

namespace gimm {
namespace detail {

/// Sampled Gaussian derivative of order 0, 1 or 2 at sigma, truncated at 4 sigma.
inline std::vector<double> gaussian_kernel(double sigma, int order) {
  const int half = static_cast<int>(std::ceil(4 * sigma));
  std::vector<double> k(static_cast<std::size_t>(2 * half + 1));
  double sum = 0;
  for (int x = -half; x <= half; ++x) sum += std::exp(-0.5 * x * x / (sigma * sigma));
  for (int x = -half; x <= half; ++x) {
    const double g = std::exp(-0.5 * x * x / (sigma * sigma)) / sum;
    const double s2 = sigma * sigma;
    k[static_cast<std::size_t>(x + half)] = order == 0   ? g
                                            : order == 1 ? -x / s2 * g
                                                         : (x * x - s2) / (s2 * s2) * g;
  }
  return k;
}

/// Convolution along x (each row) with `kernel` (odd length), in float, borders replicated,
/// through a padded line buffer: the inner loops run along contiguous memory and vectorise.
/// Taps go four to a pass over the output line (one load and store of it per four taps: the
/// passes are bound by those, not by the products).
inline void convolve_rows(const Image<float>& in, const std::vector<float>& kernel,
                          Image<float>& out) {
  const int half = static_cast<int>(kernel.size() / 2), rows = in.rows(), cols = in.cols();
  const int taps = static_cast<int>(kernel.size());
  out.resize(rows, cols);  // every pixel is written below
  std::vector<float> line(static_cast<std::size_t>(cols + 2 * half));
  // out(c) = sum_k K[k] in(c - k): tap j of the line is in(c + j - half), weight K[taps - 1 - j].
  const auto weight = [&](int j) { return kernel[static_cast<std::size_t>(taps - 1 - j)]; };
  for (int r = 0; r < rows; ++r) {
    const float* src = in.data() + static_cast<std::size_t>(r) * cols;
    std::fill(line.begin(), line.begin() + half, src[0]);
    std::copy(src, src + cols, line.begin() + half);
    std::fill(line.begin() + half + cols, line.end(), src[cols - 1]);
    float* dst = out.data() + static_cast<std::size_t>(r) * cols;
    std::fill(dst, dst + cols, 0.0f);
    int j = 0;
    for (; j + 4 <= taps; j += 4) {
      const float w0 = weight(j), w1 = weight(j + 1), w2 = weight(j + 2), w3 = weight(j + 3);
      const float* x = line.data() + j;
      for (int c = 0; c < cols; ++c)
        dst[c] += (w0 * x[c] + w1 * x[c + 1]) + (w2 * x[c + 2] + w3 * x[c + 3]);
    }
    for (; j < taps; ++j) {
      const float w = weight(j);
      const float* x = line.data() + j;
      for (int c = 0; c < cols; ++c) dst[c] += w * x[c];
    }
  }
}

/// Convolution along y (each column) as weighted sums of whole rows, borders replicated, four
/// rows to a pass as convolve_rows().
inline void convolve_cols(const Image<float>& in, const std::vector<float>& kernel,
                          Image<float>& out) {
  const int half = static_cast<int>(kernel.size() / 2), rows = in.rows(), cols = in.cols();
  out.resize(rows, cols);  // every pixel is written below
  // out(r) = sum_k K[half + k] in(r - k)
  const auto weight = [&](int k) { return kernel[static_cast<std::size_t>(k + half)]; };
  const auto row = [&](int r) {
    return in.data() + static_cast<std::size_t>(std::clamp(r, 0, rows - 1)) * cols;
  };
  for (int r = 0; r < rows; ++r) {
    float* dst = out.data() + static_cast<std::size_t>(r) * cols;
    std::fill(dst, dst + cols, 0.0f);
    int k = -half;
    for (; k + 3 <= half; k += 4) {
      const float w0 = weight(k), w1 = weight(k + 1), w2 = weight(k + 2), w3 = weight(k + 3);
      const float *s0 = row(r - k), *s1 = row(r - k - 1), *s2 = row(r - k - 2),
                  *s3 = row(r - k - 3);
      for (int c = 0; c < cols; ++c)
        dst[c] += (w0 * s0[c] + w1 * s1[c]) + (w2 * s2[c] + w3 * s3[c]);
    }
    for (; k <= half; ++k) {
      const float w = weight(k);
      const float* s0 = row(r - k);
      for (int c = 0; c < cols; ++c) dst[c] += w * s0[c];
    }
  }
}

}  // namespace detail

/// Gaussian blur at `sigma` pixels (truncated at 4 sigma); sigma 0 returns the image unchanged.
inline Image<float> gaussian_blur(const Image<float>& image, double sigma) {
  GIMM_CHECK(std::isfinite(sigma) && sigma >= 0 && sigma <= 64,
             "gaussian_blur: sigma must be in [0, 64] px, got " << sigma);
  if (sigma == 0 || image.empty()) return image;
  const std::vector<double> k64 = detail::gaussian_kernel(sigma, 0);
  const std::vector<float> k(k64.begin(), k64.end());
  Image<float> along_x, out;
  detail::convolve_rows(image, k, along_x);
  detail::convolve_cols(along_x, k, out);
  return out;
}

}  // namespace gimm
