#pragma once
/// Bilinear 2x upsampling with PyTorch's align_corners=True semantics, and the extraction of
/// local windows (PyTorch unfold, restricted to the centres the matcher asks for).
#include <algorithm>
#include <cstdint>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/core/parallel.hpp"
#include "gimm/nn/tensor.hpp"

namespace gimm::nn {

/// [N, C, H, W] -> [N, C, out_h, out_w]; align_corners=True: output index o samples the input
/// at o (in - 1) / (out - 1), so the corner pixels map onto each other.
inline Tensor upsample_bilinear(const Tensor& x, std::int64_t out_h, std::int64_t out_w) {
  x.expect_rank(4, "upsample input");
  GIMM_CHECK(out_h > 0 && out_w > 0, "upsample: bad output size " << out_h << "x" << out_w);
  const std::int64_t n = x.dim(0), c = x.dim(1), h = x.dim(2), w = x.dim(3);
  GIMM_CHECK(h > 0 && w > 0, "upsample: empty input " << shape_string(x.shape()));
  // float arithmetic, as PyTorch's CPU kernel, so the weights agree to the last bit or two.
  const float sy = out_h > 1 ? float(h - 1) / float(out_h - 1) : 0.0f;
  const float sx = out_w > 1 ? float(w - 1) / float(out_w - 1) : 0.0f;
  std::vector<std::int64_t> x0(static_cast<std::size_t>(out_w)), x1(x0.size());
  std::vector<float> wx(x0.size());
  for (std::int64_t o = 0; o < out_w; ++o) {
    const float src = sx * float(o);
    x0[o] = std::min<std::int64_t>(static_cast<std::int64_t>(src), w - 1);
    x1[o] = std::min<std::int64_t>(x0[o] + 1, w - 1);
    wx[o] = src - float(x0[o]);
  }
  Tensor out({n, c, out_h, out_w});
  parallel_for(0, n * c, [&](std::int64_t plane) {
    const float* in = x.data() + plane * h * w;
    float* dst = out.data() + plane * out_h * out_w;
    for (std::int64_t oy = 0; oy < out_h; ++oy) {
      const float src = sy * float(oy);
      const std::int64_t y0 = std::min<std::int64_t>(static_cast<std::int64_t>(src), h - 1);
      const std::int64_t y1 = std::min<std::int64_t>(y0 + 1, h - 1);
      const float wy = src - float(y0);
      const float* r0 = in + y0 * w;
      const float* r1 = in + y1 * w;
      for (std::int64_t ox = 0; ox < out_w; ++ox) {
        const float top = (1.0f - wx[ox]) * r0[x0[ox]] + wx[ox] * r0[x1[ox]];
        const float bottom = (1.0f - wx[ox]) * r1[x0[ox]] + wx[ox] * r1[x1[ox]];
        dst[oy * out_w + ox] = (1.0f - wy) * top + wy * bottom;
      }
    }
  });
  return out;
}

/// Windows of `window` x `window` pixels of a [C, H, W] map (one image of a [N, C, H, W]
/// tensor: pass its data pointer), centred on (rows[m], cols[m]), zero outside the map.
/// Returns [M, window^2, C], window pixels in row-major order: the token layout of the fine
/// transformer.
inline Tensor extract_windows(const float* map, std::int64_t c, std::int64_t h, std::int64_t w,
                              const std::vector<std::int64_t>& rows,
                              const std::vector<std::int64_t>& cols, int window) {
  GIMM_CHECK(rows.size() == cols.size(),
             "extract_windows: " << rows.size() << " rows but " << cols.size() << " cols");
  GIMM_CHECK(window >= 1 && window % 2 == 1, "extract_windows: window must be odd, got " << window);
  const std::int64_t m = static_cast<std::int64_t>(rows.size()), ww = window * window;
  const int half = window / 2;
  Tensor out({m, ww, c});
  for (std::int64_t i = 0; i < m; ++i)
    for (int dy = 0; dy < window; ++dy)
      for (int dx = 0; dx < window; ++dx) {
        const std::int64_t y = rows[i] - half + dy, x = cols[i] - half + dx;
        float* dst = out.data() + (i * ww + dy * window + dx) * c;
        if (y < 0 || y >= h || x < 0 || x >= w) continue;  // zero padding
        for (std::int64_t ch = 0; ch < c; ++ch) dst[ch] = map[(ch * h + y) * w + x];
      }
  return out;
}

}  // namespace gimm::nn
