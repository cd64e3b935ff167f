#pragma once
/// LoFTR's multi-head linear attention (Katharopoulos et al. 2020) with the feature map
/// phi(x) = elu(x) + 1:
///   out[l] = sum_s (phi(q_l) . phi(k_s)) v_s / (sum_s phi(q_l) . phi(k_s) + eps), per head.
/// q is [N, L, C], k and v are [N, S, C], C = heads x head_dim, head h owns channels
/// [h D, (h + 1) D). linear_attention_reference evaluates the quadratic sum above directly;
/// linear_attention factorises it as phi(Q) (phi(K)^T V), which is O((L + S) D^2).
#include <Eigen/Core>
#include <cstdint>

#include "gimm/core/error.hpp"
#include "gimm/core/parallel.hpp"
#include "gimm/nn/activations.hpp"
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
  const Tensor fq = detail::feature_map(q), fk = detail::feature_map(k);
  Tensor out(q.shape());
  parallel_for(
      0, n * heads,
      [&](std::int64_t task) {
        const std::int64_t b = task / heads, h = task % heads;
        const auto qm = matrix(fq.data() + b * l * c + h * d, l, d, c);
        const auto km = matrix(fk.data() + b * s * c + h * d, s, d, c);
        const auto vm = matrix(v.data() + b * s * c + h * d, s, d, c);
        auto om = matrix(out.data() + b * l * c + h * d, l, d, c);
        const RowMatrix kv = km.transpose() * vm;               // [D, D]
        const Eigen::RowVectorXf key_sum = km.colwise().sum();  // [D]
        om.noalias() = qm * kv;
        const Eigen::VectorXf norm = qm * key_sum.transpose();  // [L]
        for (std::int64_t i = 0; i < l; ++i) om.row(i) /= (norm(i) + kLinearAttentionEps);
      },
      1);
  return out;
}

}  // namespace gimm::nn
