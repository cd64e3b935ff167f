#pragma once
/// LoFTR's multi-head linear attention (Katharopoulos et al. 2020) with the feature map
/// phi(x) = elu(x) + 1:
///   out[l] = sum_s (phi(q_l) . phi(k_s)) v_s / (sum_s phi(q_l) . phi(k_s) + eps), per head.
/// q is [N, L, C], k and v are [N, S, C], C = heads x head_dim, head h owns channels
/// [h D, (h + 1) D). linear_attention_reference evaluates the quadratic sum above directly;
/// linear_attention factorises it as phi(Q) (phi(K)^T V), which is O((L + S) D^2).
#include <cstdint>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/core/parallel.hpp"
#include "gimm/nn/activations.hpp"
#include "gimm/nn/fast_exp.hpp"
#include "gimm/nn/gemm.hpp"
#include "gimm/nn/tensor.hpp"

namespace gimm::nn {

constexpr float kLinearAttentionEps = 1e-6f;

namespace detail {
inline void check_attention(const Tensor& q, const Tensor& k, const Tensor& v, int heads) {
  q.expect_rank(3, "attention queries");
  k.expect_rank(3, "attention keys");
  v.expect_shape(k.shape(), "attention values");
  GIMM_CHECK(q.dim(0) == k.dim(0) && q.dim(2) == k.dim(2),
             "attention: queries " << shape_string(q.shape()) << " and keys "
                                   << shape_string(k.shape()) << " disagree");
  GIMM_CHECK(heads > 0 && q.dim(2) % heads == 0,
             "attention: " << q.dim(2) << " channels do not split into " << heads << " heads");
}
inline Tensor feature_map(const Tensor& x) {
  Tensor y = x;
  for (float& value : y.values()) value = elu(value) + 1.0f;
  return y;
}
}  // namespace detail

inline Tensor linear_attention_reference(const Tensor& q, const Tensor& k, const Tensor& v,
                                         int heads) {
  detail::check_attention(q, k, v, heads);
  const std::int64_t n = q.dim(0), l = q.dim(1), s = k.dim(1), c = q.dim(2), d = c / heads;
  const Tensor fq = detail::feature_map(q), fk = detail::feature_map(k);
  Tensor out(q.shape());
  for (std::int64_t b = 0; b < n; ++b)
    for (std::int64_t h = 0; h < heads; ++h)
      for (std::int64_t i = 0; i < l; ++i) {
        double norm = 0;
        std::vector<double> acc(static_cast<std::size_t>(d), 0.0);
        for (std::int64_t j = 0; j < s; ++j) {
          double a = 0;
          for (std::int64_t e = 0; e < d; ++e)
            a += double(fq.at(b, i, h * d + e)) * fk.at(b, j, h * d + e);
          norm += a;
          for (std::int64_t e = 0; e < d; ++e)
            acc[static_cast<std::size_t>(e)] += a * v.at(b, j, h * d + e);
        }
        for (std::int64_t e = 0; e < d; ++e)
          out.at(b, i, h * d + e) =
              float(acc[static_cast<std::size_t>(e)] / (norm + kLinearAttentionEps));
      }
  return out;
}

inline Tensor linear_attention(const Tensor& q, const Tensor& k, const Tensor& v, int heads) {
  detail::check_attention(q, k, v, heads);
  const std::int64_t n = q.dim(0), l = q.dim(1), s = k.dim(1), c = q.dim(2), d = c / heads;
  // phi(x) = elu(x) + 1 = x + 1 for x > 0, exp(x) otherwise (vectorised, fast_exp).
  auto phi = [](const Tensor& x) {
    Tensor y(x.shape());
    const float* in = x.data();
    float* out = y.data();
    for (std::int64_t i = 0; i < x.numel(); ++i)
      out[i] = in[i] > 0.0f ? in[i] + 1.0f : fast_exp(in[i]);
    return y;
  };
  const Tensor fq = phi(q), fk = phi(k);
  Tensor out(q.shape());
  // Plain loops: heads are small (D = 6..32), where Eigen's dynamic products cost more in
  // allocations than in arithmetic.
  parallel_for(0, n * heads, [&](std::int64_t task) {
    const std::int64_t b = task / heads, h = task % heads;
    thread_local std::vector<float> kv, key_sum;
    kv.assign(static_cast<std::size_t>(d * d), 0.0f);
    key_sum.assign(static_cast<std::size_t>(d), 0.0f);
    float* __restrict kv_p = kv.data();
    float* __restrict sum_p = key_sum.data();
    for (std::int64_t j = 0; j < s; ++j) {
      const float* __restrict kj = fk.data() + (b * s + j) * c + h * d;
      const float* __restrict vj = v.data() + (b * s + j) * c + h * d;
      for (std::int64_t e = 0; e < d; ++e) {
        sum_p[e] += kj[e];
        for (std::int64_t f = 0; f < d; ++f) kv_p[e * d + f] += kj[e] * vj[f];
      }
    }
    for (std::int64_t i = 0; i < l; ++i) {
      const float* __restrict qi = fq.data() + (b * l + i) * c + h * d;
      float* __restrict oi = out.data() + (b * l + i) * c + h * d;
      float norm = 0.0f;
      for (std::int64_t e = 0; e < d; ++e) {
        norm += qi[e] * sum_p[e];
        for (std::int64_t f = 0; f < d; ++f) oi[f] += qi[e] * kv_p[e * d + f];
      }
      const float inv = 1.0f / (norm + kLinearAttentionEps);
      for (std::int64_t f = 0; f < d; ++f) oi[f] *= inv;
    }
  });
  return out;
}

}  // namespace gimm::nn
