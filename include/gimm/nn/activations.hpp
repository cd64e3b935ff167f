#pragma once
/// Elementwise ops, in place: ReLU, ELU (alpha 1, as in the LoFTR feature map elu(x) + 1) and
/// add. They are single loops; the compiler vectorises them, so there is no separate fast path.
#include <cmath>
#include <cstdint>

#include "gimm/nn/tensor.hpp"

namespace gimm::nn {

inline void relu_inplace(float* x, std::int64_t count) {
  for (std::int64_t i = 0; i < count; ++i) x[i] = x[i] < 0.0f ? 0.0f : x[i];
}
inline void relu_inplace(Tensor& x) {
  relu_inplace(x.data(), x.numel());
}

/// elu(x) = x for x > 0, exp(x) - 1 otherwise (alpha = 1).
inline float elu(float x) {
  return x > 0.0f ? x : std::expm1(x);
}
inline void elu_inplace(Tensor& x) {
  for (float& v : x.values()) v = elu(v);
}

/// a += b, same shapes.
inline void add_inplace(Tensor& a, const Tensor& b) {
  b.expect_shape(a.shape(), "add");
  float* pa = a.data();
  const float* pb = b.data();
  for (std::int64_t i = 0; i < a.numel(); ++i) pa[i] += pb[i];
}

}  // namespace gimm::nn
