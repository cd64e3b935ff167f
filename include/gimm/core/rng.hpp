#pragma once
/// Rng: a deterministic random number generator whose stream is the same on every platform,
/// compiler and standard library.
///
/// std::uniform_real_distribution and friends are implementation-defined, so nothing that can
/// reach an output file may use them. Rng is SplitMix64 (Steele, Lea, Flood 2014) for seeding
/// and xoshiro256** (Blackman, Vigna 2018) for the stream; every distribution below is written
/// out here with integer arithmetic or IEEE-754 basic operations, except normal(), whose
/// Box-Muller transform calls std::log, std::sqrt and std::cos (correctly rounded sqrt; glibc's
/// log and cos are within 1 ulp and identical across x86-64 builds).
///
/// Not thread-safe: give each thread (or each work item, for results independent of the thread
/// count) its own Rng, e.g. Rng(seed).fork(item_index).
#include <cmath>
#include <cstdint>
#include <limits>

#include "gimm/core/error.hpp"

namespace gimm {

class Rng {
 public:
  explicit Rng(std::uint64_t seed = 0) { reseed(seed); }

  void reseed(std::uint64_t seed) {
    std::uint64_t x = seed;
    for (auto& word : state_) word = splitmix64(x);
    has_spare_normal_ = false;
  }

  /// An independent generator for sub-stream `index` (a patient, a pixel row, a view): its
  /// stream depends on this generator's current state and `index` (fork before drawing, as the
  /// pipeline does, and it depends only on the seed). Forking does not advance this generator.
  Rng fork(std::uint64_t index) const {
    std::uint64_t x = state_[0] ^ (state_[3] * 0x9E3779B97F4A7C15ull) ^
                      (index + 0x632BE59BD9B4E019ull) * 0xBF58476D1CE4E5B9ull;
    return Rng(splitmix64(x));
  }

  /// Next 64 random bits (xoshiro256**).
  std::uint64_t next_u64() {
    const std::uint64_t result = rotl(state_[1] * 5, 7) * 9;
    const std::uint64_t t = state_[1] << 17;
    state_[2] ^= state_[0];
    state_[3] ^= state_[1];
    state_[1] ^= state_[2];
    state_[0] ^= state_[3];
    state_[2] ^= t;
    state_[3] = rotl(state_[3], 45);
    return result;
  }

  /// Uniform double in [0, 1), 53 random bits.
  double uniform() { return static_cast<double>(next_u64() >> 11) * 0x1.0p-53; }

  /// Uniform double in [lo, hi).
  double uniform(double lo, double hi) {
    GIMM_CHECK(std::isfinite(lo) && std::isfinite(hi) && lo <= hi,
               "Rng::uniform: need finite lo <= hi, got [" << lo << ", " << hi << ")");
    return lo + (hi - lo) * uniform();
  }

  /// Uniform integer in [0, n), unbiased (Lemire's multiply-shift with rejection).
  std::uint64_t below(std::uint64_t n) {
    GIMM_CHECK(n > 0, "Rng::below: n must be positive, got " << n);
    unsigned __int128 m = static_cast<unsigned __int128>(next_u64()) * n;
    auto low = static_cast<std::uint64_t>(m);
    if (low < n) {
      const std::uint64_t threshold = (0 - n) % n;
      while (low < threshold) {
        m = static_cast<unsigned __int128>(next_u64()) * n;
        low = static_cast<std::uint64_t>(m);
      }
    }
    return static_cast<std::uint64_t>(m >> 64);
  }

  /// Uniform integer in [lo, hi] (inclusive).
  std::int64_t uniform_int(std::int64_t lo, std::int64_t hi) {
    GIMM_CHECK(lo <= hi, "Rng::uniform_int: need lo <= hi, got [" << lo << ", " << hi << "]");
    // Unsigned (modular) arithmetic: hi - lo overflows std::int64_t for wide ranges.
    const auto ulo = static_cast<std::uint64_t>(lo);
    const std::uint64_t span = static_cast<std::uint64_t>(hi) - ulo + 1;
    if (span == 0) return static_cast<std::int64_t>(next_u64());  // full 64-bit range
    return static_cast<std::int64_t>(ulo + below(span));
  }

  /// Standard normal N(0, 1) by the Box-Muller transform (pairs cached).
  double normal() {
    if (has_spare_normal_) {
      has_spare_normal_ = false;
      return spare_normal_;
    }
    double u1 = 0.0;
    do {
      u1 = uniform();
    } while (u1 <= 0.0);
    const double u2 = uniform();
    const double radius = std::sqrt(-2.0 * std::log(u1));
    const double angle = 6.283185307179586476925 * u2;
    spare_normal_ = radius * std::sin(angle);
    has_spare_normal_ = true;
    return radius * std::cos(angle);
  }

  /// N(mean, sigma^2).
  double normal(double mean, double sigma) {
    GIMM_CHECK(std::isfinite(sigma) && sigma >= 0,
               "Rng::normal: sigma must be finite and >= 0, got " << sigma);
    return mean + sigma * normal();
  }

 private:
  static std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  static std::uint64_t splitmix64(std::uint64_t& x) {
    std::uint64_t z = (x += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }

  std::uint64_t state_[4] = {};
  bool has_spare_normal_ = false;
  double spare_normal_ = 0.0;
};

}  // namespace gimm
