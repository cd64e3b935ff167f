#pragma once
/// Linear layers, layer norm and embedding over token rows: x is [..., C] and every leading
/// axis is a row (a [N, L, C] sequence is N L rows of C).
///
/// linear_reference is the dot-product definition; linear is one GEMM over all rows, split in
/// row blocks across threads.
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

struct Linear {
  Tensor weight;            ///< [out, in], PyTorch's layout
  std::vector<float> bias;  ///< [out]; zeros for a layer without bias

  std::int64_t in_features() const { return weight.dim(1); }
  std::int64_t out_features() const { return weight.dim(0); }

  static Linear from(Tensor weight, const Tensor* bias, const std::string& name) {
    GIMM_CHECK(weight.rank() == 2 && weight.dim(0) > 0 && weight.dim(1) > 0,
               name << ": linear weight must be [out, in], got " << shape_string(weight.shape()));
    Linear layer;
    layer.bias.assign(static_cast<std::size_t>(weight.dim(0)), 0.0f);
    if (bias) {
      bias->expect_shape({weight.dim(0)}, name + ".bias");
      layer.bias = bias->values();
    }
    layer.weight = std::move(weight);
    return layer;
  }
};

namespace detail {
inline Shape with_last(const Shape& shape, std::int64_t last) {
  Shape out = shape;
  out.back() = last;
  return out;
}
inline void check_rows(const Tensor& x, std::int64_t features, const char* what) {
  GIMM_CHECK(x.rank() >= 1 && x.dim(-1) == features,
             what << ": input " << shape_string(x.shape()) << " must end in " << features);
}
}  // namespace detail

inline Tensor linear_reference(const Tensor& x, const Linear& layer) {
  detail::check_rows(x, layer.in_features(), "linear");
  const std::int64_t in = layer.in_features(), out = layer.out_features(), rows = x.numel() / in;
  Tensor y(detail::with_last(x.shape(), out));
  for (std::int64_t r = 0; r < rows; ++r)
    for (std::int64_t o = 0; o < out; ++o) {
      double sum = layer.bias[static_cast<std::size_t>(o)];
      for (std::int64_t i = 0; i < in; ++i) sum += double(x[r * in + i]) * layer.weight.at(o, i);
      y[r * out + o] = float(sum);
    }
  return y;
}

/// y = x W^T + b, optionally followed by ReLU.
inline Tensor linear(const Tensor& x, const Linear& layer, bool relu = false) {
  detail::check_rows(x, layer.in_features(), "linear");
  const std::int64_t in = layer.in_features(), out = layer.out_features(), rows = x.numel() / in;
  Tensor y(detail::with_last(x.shape(), out));
  const std::int64_t block = 256;
  parallel_for(0, (rows + block - 1) / block, [&](std::int64_t task) {
    const std::int64_t r0 = task * block, r1 = std::min(rows, r0 + block);
    float* dst = y.data() + r0 * out;
    gemm(x.data() + r0 * in, in, layer.weight.data(), in, dst, out, r1 - r0, out, in, true, false);
    for (std::int64_t r = 0; r < r1 - r0; ++r)
      for (std::int64_t o = 0; o < out; ++o) {
        float v = dst[r * out + o] + layer.bias[static_cast<std::size_t>(o)];
        dst[r * out + o] = (relu && v < 0.0f) ? 0.0f : v;
      }
  });
  return y;
}

/// PyTorch LayerNorm over the last axis: (x - mean) / sqrt(biased var + eps) * gamma + beta.
inline void layer_norm_inplace(Tensor& x, const Tensor& gamma, const Tensor& beta,
                               float eps = 1e-5f) {
  const std::int64_t c = gamma.numel();
  GIMM_CHECK(c > 0, "layer_norm: empty gamma " << shape_string(gamma.shape()));
  detail::check_rows(x, c, "layer_norm");
  beta.expect_shape(gamma.shape(), "layer_norm beta");
  const std::int64_t rows = x.numel() / c;
  parallel_for(
      0, rows,
      [&](std::int64_t r) {
        float* v = x.data() + r * c;
        double mean = 0, var = 0;
        for (std::int64_t i = 0; i < c; ++i) mean += v[i];
        mean /= double(c);
        for (std::int64_t i = 0; i < c; ++i) var += (v[i] - mean) * (v[i] - mean);
        const float inv = float(1.0 / std::sqrt(var / double(c) + eps));
        for (std::int64_t i = 0; i < c; ++i) v[i] = (v[i] - float(mean)) * inv * gamma[i] + beta[i];
      },
      1024);
}

/// Row `index` of an embedding table [count, dim].
inline Tensor embedding(const Tensor& table, std::int64_t index, const std::string& name) {
  table.expect_rank(2, name);
  GIMM_CHECK(index >= 0 && index < table.dim(0),
             name << ": index " << index << " outside [0, " << table.dim(0) << ")");
  const std::int64_t d = table.dim(1);
  return Tensor({d}, std::vector<float>(table.data() + index * d, table.data() + (index + 1) * d));
}

}  // namespace gimm::nn
