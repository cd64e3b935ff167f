#pragma once
/// LoFTR's 2D sine positional encoding, added to the coarse features.
///
/// For channel group g (4 channels each, g < C/4) and 1-based positions x, y:
///   div_g = exp(2g (-ln 10000) / (C/2)),
///   pe[4g] = sin(x div_g), pe[4g+1] = cos(x div_g), pe[4g+2] = sin(y div_g), pe[4g+3] = cos(y
///   div_g).
/// Computed in float like tools/train/gimm_model.py:sine_encoding.
#include <cmath>
#include <cstdint>

#include "gimm/core/error.hpp"
#include "gimm/nn/tensor.hpp"

namespace gimm::nn {

/// [C, H, W]; C must be a multiple of 4.
inline Tensor sine_encoding(std::int64_t channels, std::int64_t height, std::int64_t width) {
  GIMM_CHECK(channels > 0 && channels % 4 == 0,
             "sine_encoding: channels must be a positive multiple of 4, got " << channels);
  Tensor pe({channels, height, width});
  const float step = float(-std::log(10000.0) / double(channels / 2));
  for (std::int64_t g = 0; g < channels / 4; ++g) {
    const float div = std::exp(float(2 * g) * step);
    for (std::int64_t y = 0; y < height; ++y)
      for (std::int64_t x = 0; x < width; ++x) {
        const float ax = float(x + 1) * div, ay = float(y + 1) * div;
        pe.at(4 * g, y, x) = std::sin(ax);
        pe.at(4 * g + 1, y, x) = std::cos(ax);
        pe.at(4 * g + 2, y, x) = std::sin(ay);
        pe.at(4 * g + 3, y, x) = std::cos(ay);
      }
  }
  return pe;
}

}  // namespace gimm::nn
