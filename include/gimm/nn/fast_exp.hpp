#pragma once
/// fast_exp: expf without a libm call, so that loops over it vectorise (AVX2/AVX-512). libm's
/// expf is one scalar call per element, which made exp the largest cost of the dual softmax.
///
/// Cody-Waite reduction x = n ln2 + r (|r| <= ln2 / 2, n by the round-to-nearest magic-number
/// trick), Cephes' degree-6 polynomial for e^r, and 2^n built in the exponent bits. Relative
/// error below 3e-7 (checked against std::exp in tests/nn). Results never overflow or go
/// subnormal: below -87.3 the result is 0 (the true value is under 1.2e-38, at the edge of the
/// normal floats), above 88 it is exp(88).
#include <cstdint>
#include <cstring>

namespace gimm::nn {

inline float fast_exp(float x) {
  const bool underflow = x < -87.3f;
  x = underflow ? -87.3f : (x > 88.0f ? 88.0f : x);
  constexpr float kMagic = 12582912.0f;  // 1.5 * 2^23: adding it rounds to an integer
  const float n = (x * 1.44269504088896341f + kMagic) - kMagic;
  float r = x - n * 0.693359375f;  // ln2, high part (exact in n * C1)
  r -= n * -2.12194440e-4f;        // ln2, low part
  float p = 1.9875691500e-4f;
  p = p * r + 1.3981999507e-3f;
  p = p * r + 8.3334519073e-3f;
  p = p * r + 4.1665795894e-2f;
  p = p * r + 1.6666665459e-1f;
  p = p * r + 5.0000001201e-1f;
  p = p * r * r + r + 1.0f;
  const std::int32_t bits = (static_cast<std::int32_t>(n) + 127) << 23;
  float scale;
  std::memcpy(&scale, &bits, sizeof scale);
  return underflow ? 0.0f : p * scale;
}

}  // namespace gimm::nn
