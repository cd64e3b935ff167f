#pragma once
/// 2D convolution over [N, C, H, W] feature maps, batch norm folding, and the fused epilogue
/// (bias, residual add, ReLU) the ResNet blocks need.
///
/// conv2d_reference is the plain seven-loop definition (PyTorch's Conv2d with zero padding,
/// square kernel, no dilation or groups). conv2d is the fast path: per image and per band of
/// output rows, im2col into a cache-sized buffer, then one GEMM (weights [Cout, Cin K K] times
/// columns [Cin K K, pixels]); bands run in parallel, so the result does not depend on the
/// thread count. 1x1 stride-1 convolutions skip im2col.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/core/parallel.hpp"
#include "gimm/nn/gemm.hpp"
#include "gimm/nn/tensor.hpp"

namespace gimm::nn {

enum class Activation { none, relu };

struct Conv2d {
  Tensor weight;            ///< [Cout, Cin, K, K]
  std::vector<float> bias;  ///< [Cout]; zeros for a layer without bias
  int stride = 1;
  int padding = 0;

  std::int64_t out_channels() const { return weight.dim(0); }
  std::int64_t in_channels() const { return weight.dim(1); }
  std::int64_t kernel() const { return weight.dim(2); }

  /// From PyTorch tensors: weight [Cout, Cin, K, K] (square), bias [Cout] or none.
  static Conv2d from(Tensor weight, const Tensor* bias, int stride, int padding,
                     const std::string& name) {
    GIMM_CHECK(
        weight.rank() == 4 && weight.dim(2) == weight.dim(3) && weight.dim(0) > 0 &&
            weight.dim(1) > 0 && weight.dim(2) > 0,
        name << ": conv weight must be [Cout, Cin, K, K], got " << shape_string(weight.shape()));
    GIMM_CHECK(stride >= 1 && padding >= 0,
               name << ": bad stride " << stride << " or padding " << padding);
    Conv2d conv;
    conv.stride = stride;
    conv.padding = padding;
    conv.bias.assign(static_cast<std::size_t>(weight.dim(0)), 0.0f);
    if (bias) {
      bias->expect_shape({weight.dim(0)}, name + ".bias");
      conv.bias = bias->values();
    }
    conv.weight = std::move(weight);
    return conv;
  }
};

/// Folds an inference-mode BatchNorm2d that follows `conv` into its weights and bias:
/// y = gamma (x - mean) / sqrt(var + eps) + beta.
inline void fold_batch_norm(Conv2d& conv, const Tensor& gamma, const Tensor& beta,
                            const Tensor& mean, const Tensor& var, float eps,
                            const std::string& name) {
  const std::int64_t cout = conv.out_channels();
  for (const Tensor* t : {&gamma, &beta, &mean, &var}) t->expect_shape({cout}, name);
  const std::int64_t per_out = conv.weight.numel() / cout;
  for (std::int64_t o = 0; o < cout; ++o) {
    GIMM_CHECK(var[o] >= 0 && std::isfinite(var[o]),
               name << ": running_var[" << o << "] = " << var[o] << " is not a variance");
    const float scale = gamma[o] / std::sqrt(var[o] + eps);
    float* w = conv.weight.data() + o * per_out;
    for (std::int64_t i = 0; i < per_out; ++i) w[i] *= scale;
    conv.bias[static_cast<std::size_t>(o)] =
        (conv.bias[static_cast<std::size_t>(o)] - mean[o]) * scale + beta[o];
  }
}

namespace detail {
inline std::int64_t conv_out_size(std::int64_t in, const Conv2d& conv) {
  return (in + 2 * conv.padding - conv.kernel()) / conv.stride + 1;
}

inline void check_conv_input(const Tensor& x, const Conv2d& conv, const Tensor* residual) {
  x.expect_rank(4, "conv2d input");
  GIMM_CHECK(x.dim(1) == conv.in_channels(), "conv2d: input has " << x.dim(1)
                                                                  << " channels, the layer expects "
                                                                  << conv.in_channels());
  GIMM_CHECK(
      x.dim(2) + 2 * conv.padding >= conv.kernel() && x.dim(3) + 2 * conv.padding >= conv.kernel(),
      "conv2d: input " << shape_string(x.shape()) << " is smaller than the kernel");
  if (residual)
    residual->expect_shape({x.dim(0), conv.out_channels(), conv_out_size(x.dim(2), conv),
                            conv_out_size(x.dim(3), conv)},
                           "conv2d residual");
}

/// out = act(out + bias + residual) over `count` values of one output channel.
inline void epilogue(float* out, const float* residual, float bias, std::int64_t count,
                     Activation act) {
  for (std::int64_t i = 0; i < count; ++i) {
    float v = out[i] + bias + (residual ? residual[i] : 0.0f);
    out[i] = (act == Activation::relu && v < 0.0f) ? 0.0f : v;
  }
}
}  // namespace detail

/// The definition: out[n, o, y, x] = act(bias[o] + residual + sum_{c, ky, kx}
/// w[o, c, ky, kx] in[n, c, y s - p + ky, x s - p + kx]), zero outside the input.
inline Tensor conv2d_reference(const Tensor& x, const Conv2d& conv,
                               Activation act = Activation::none,
                               const Tensor* residual = nullptr) {
  detail::check_conv_input(x, conv, residual);
  const std::int64_t n = x.dim(0), cin = x.dim(1), h = x.dim(2), w = x.dim(3);
  const std::int64_t cout = conv.out_channels(), k = conv.kernel();
  const std::int64_t ho = detail::conv_out_size(h, conv), wo = detail::conv_out_size(w, conv);
  Tensor out({n, cout, ho, wo});
  for (std::int64_t b = 0; b < n; ++b)
    for (std::int64_t o = 0; o < cout; ++o)
      for (std::int64_t y = 0; y < ho; ++y)
        for (std::int64_t xo = 0; xo < wo; ++xo) {
          double sum = conv.bias[static_cast<std::size_t>(o)];
          for (std::int64_t c = 0; c < cin; ++c)
            for (std::int64_t ky = 0; ky < k; ++ky)
              for (std::int64_t kx = 0; kx < k; ++kx) {
                const std::int64_t iy = y * conv.stride - conv.padding + ky;
                const std::int64_t ix = xo * conv.stride - conv.padding + kx;
                if (iy < 0 || iy >= h || ix < 0 || ix >= w) continue;
                sum += double(conv.weight.at(o, c, ky, kx)) * x.at(b, c, iy, ix);
              }
          if (residual) sum += residual->at(b, o, y, xo);
          out.at(b, o, y, xo) = (act == Activation::relu && sum < 0) ? 0.0f : float(sum);
        }
  return out;
}

/// Fast path: banded im2col + GEMM with the epilogue fused (see the file comment).
inline Tensor conv2d(const Tensor& x, const Conv2d& conv, Activation act = Activation::none,
                     const Tensor* residual = nullptr) {
  detail::check_conv_input(x, conv, residual);
  const std::int64_t n = x.dim(0), cin = x.dim(1), h = x.dim(2), w = x.dim(3);
  const std::int64_t cout = conv.out_channels(), k = conv.kernel();
  const std::int64_t s = conv.stride, p = conv.padding;
  const std::int64_t ho = detail::conv_out_size(h, conv), wo = detail::conv_out_size(w, conv);
  const std::int64_t rows_k = cin * k * k, plane = ho * wo;
  const bool pointwise = (k == 1 && s == 1 && p == 0);
  // A band of output rows whose columns fit in about 512 KiB (L2), at least one row.
  const std::int64_t band = std::clamp<std::int64_t>(
      (std::int64_t{128} << 10) / std::max<std::int64_t>(1, rows_k * wo), 1, ho);
  const std::int64_t bands = (ho + band - 1) / band;
  Tensor out({n, cout, ho, wo});

  parallel_for(0, n * bands, [&](std::int64_t task) {
    const std::int64_t b = task / bands, y0 = (task % bands) * band;
    const std::int64_t y1 = std::min(ho, y0 + band), pixels = (y1 - y0) * wo;
    const float* in = x.data() + b * cin * h * w;
    float* dst = out.data() + b * cout * plane + y0 * wo;
    if (pointwise) {
      gemm(conv.weight.data(), rows_k, in + y0 * wo, h * w, dst, plane, cout, pixels, rows_k, false,
           false);
    } else {
      thread_local std::vector<float> columns;
      columns.resize(static_cast<std::size_t>(rows_k * pixels));
      for (std::int64_t c = 0; c < cin; ++c)
        for (std::int64_t ky = 0; ky < k; ++ky)
          for (std::int64_t kx = 0; kx < k; ++kx) {
            float* col = columns.data() + ((c * k + ky) * k + kx) * pixels;
            const float* channel = in + c * h * w;
            // Output columns whose input column ix = xo s - p + kx lies inside [0, w).
            const std::int64_t x_lo = std::min(wo, std::max<std::int64_t>(0, (p - kx + s - 1) / s));
            const std::int64_t last = w - 1 + p - kx;  // largest xo s with ix < w
            const std::int64_t x_hi = std::max(x_lo, std::min(wo, last < 0 ? 0 : last / s + 1));
            for (std::int64_t y = y0; y < y1; ++y) {
              const std::int64_t iy = y * s - p + ky;
              float* row = col + (y - y0) * wo;
              if (iy < 0 || iy >= h) {
                std::fill(row, row + wo, 0.0f);
                continue;
              }
              const float* src = channel + iy * w - p + kx;  // src[xo s] is input column ix
              std::fill(row, row + x_lo, 0.0f);
              if (s == 1) {
                std::copy(src + x_lo, src + x_hi, row + x_lo);
              } else {
                for (std::int64_t xo = x_lo; xo < x_hi; ++xo) row[xo] = src[xo * s];
              }
              std::fill(row + x_hi, row + wo, 0.0f);
            }
          }
      gemm(conv.weight.data(), rows_k, columns.data(), pixels, dst, plane, cout, pixels, rows_k,
           false, false);
    }
    const float* res = residual ? residual->data() + b * cout * plane + y0 * wo : nullptr;
    for (std::int64_t o = 0; o < cout; ++o)
      detail::epilogue(dst + o * plane, res ? res + o * plane : nullptr,
                       conv.bias[static_cast<std::size_t>(o)], pixels, act);
  });
  return out;
}

}  // namespace gimm::nn
