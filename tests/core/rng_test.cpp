// Rng: xoshiro256** seeded by SplitMix64. The literal constants below pin the streams: they
// must be the same on every platform, compiler and thread count (cross-platform determinism).
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <limits>
#include <set>
#include <vector>

#include "gimm/core/rng.hpp"

using gimm::Rng;

namespace {

/// Independent transcription of the published reference algorithms (SplitMix64 and
/// xoshiro256** by Vigna), to check Rng against the algorithm and not only against itself.
struct ReferenceXoshiro {
  std::uint64_t s[4];
  explicit ReferenceXoshiro(std::uint64_t seed) {
    for (auto& word : s) {
      std::uint64_t z = (seed += 0x9e3779b97f4a7c15ull);
      z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
      z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
      word = z ^ (z >> 31);
    }
  }
  static std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  std::uint64_t next() {
    const std::uint64_t result = rotl(s[1] * 5, 7) * 9;
    const std::uint64_t t = s[1] << 17;
    s[2] ^= s[0];
    s[3] ^= s[1];
    s[1] ^= s[2];
    s[0] ^= s[3];
    s[2] ^= t;
    s[3] = rotl(s[3], 45);
    return result;
  }
};

}  // namespace

TEST_CASE("Rng streams are pinned to literal constants", "[core][rng]") {
  SECTION("seed 0") {
    Rng rng(0);
    CHECK(rng.next_u64() == 0x99ec5f36cb75f2b4ull);
    CHECK(rng.next_u64() == 0xbf6e1f784956452aull);
    CHECK(rng.next_u64() == 0x1a5f849d4933e6e0ull);
    CHECK(rng.next_u64() == 0x6aa594f1262d2d2cull);
  }
  SECTION("seed 20240917") {
    Rng rng(20240917);
    CHECK(rng.next_u64() == 0xf4fb4b524df85d22ull);
    CHECK(rng.next_u64() == 0xfc1fc909b04cf43bull);
    CHECK(rng.next_u64() == 0x2ec85ac212c41908ull);
    CHECK(rng.next_u64() == 0x8c7662d9518c3588ull);
  }
  SECTION("fork") {
    Rng child = Rng(20240917).fork(7);
    CHECK(child.next_u64() == 0xc96ba23a6fcb7b7full);
    CHECK(child.next_u64() == 0x729d83d07e52b59bull);
  }
  SECTION("uniform, below and normal") {
    Rng u(42);
    CHECK(u.uniform() == 0.083862971059882163);
    CHECK(u.uniform() == 0.37898025066266861);
    CHECK(u.uniform() == 0.68004341102813937);
    Rng b(42);
    const std::uint64_t expected_below[] = {83, 378, 680, 924, 991};
    for (std::uint64_t e : expected_below) CHECK(b.below(1000) == e);
    // normal() goes through std::log/sqrt/cos/sin: allow a few ulp across libms.
    Rng n(42);
    CHECK(n.normal() == Approx(-1.6132237513849161).epsilon(1e-14));
    CHECK(n.normal() == Approx(1.5344873235334195).epsilon(1e-14));
    CHECK(n.normal() == Approx(0.78169204505734891).epsilon(1e-14));
  }
}

TEST_CASE("Rng matches the reference SplitMix64 + xoshiro256**", "[core][rng]") {
  for (std::uint64_t seed : {0ull, 1ull, 12345ull, 0xffffffffffffffffull}) {
    Rng rng(seed);
    ReferenceXoshiro ref(seed);
    for (int n = 0; n < 1000; ++n) REQUIRE(rng.next_u64() == ref.next());
  }
}

TEST_CASE("Rng: same seed, same stream; reseed restarts it", "[core][rng]") {
  Rng a(99), b(99), c(100);
  std::vector<std::uint64_t> first;
  bool all_equal_c = true;
  for (int n = 0; n < 64; ++n) {
    const auto x = a.next_u64();
    first.push_back(x);
    CHECK(x == b.next_u64());
    all_equal_c = all_equal_c && x == c.next_u64();
  }
  CHECK_FALSE(all_equal_c);
  a.reseed(99);
  for (int n = 0; n < 64; ++n) CHECK(a.next_u64() == first[static_cast<std::size_t>(n)]);
  // reseed also drops a cached Box-Muller spare.
  Rng p(3), q(3);
  p.normal();  // caches a spare
  p.reseed(3);
  CHECK(p.normal() == q.normal());
  CHECK(p.normal() == q.normal());
}

TEST_CASE("Rng::uniform is in [0, 1) with mean 1/2", "[core][rng]") {
  Rng rng(7);
  const int n = 200000;
  double sum = 0, lo = 1, hi = 0;
  for (int i = 0; i < n; ++i) {
    const double x = rng.uniform();
    REQUIRE(x >= 0.0);
    REQUIRE(x < 1.0);
    sum += x;
    lo = std::min(lo, x);
    hi = std::max(hi, x);
  }
  CHECK(sum / n == Approx(0.5).margin(0.005));
  CHECK(lo < 1e-4);
  CHECK(hi > 1 - 1e-4);
  // The largest possible draw is 1 - 2^-53 (53 bits), never 1.
  CHECK(static_cast<double>(0xffffffffffffffffull >> 11) * 0x1.0p-53 < 1.0);

  Rng r(8);
  for (int i = 0; i < 10000; ++i) {
    const double x = r.uniform(-3.0, 5.0);
    REQUIRE(x >= -3.0);
    REQUIRE(x < 5.0);
  }
  CHECK(r.uniform(2.0, 2.0) == 2.0);
  CHECK_THROWS_AS(r.uniform(1.0, 0.0), gimm::Error);
  CHECK_THROWS_AS(r.uniform(0.0, std::nan("")), gimm::Error);
  CHECK_THROWS_AS(r.uniform(-std::numeric_limits<double>::infinity(), 0.0), gimm::Error);
}

TEST_CASE("Rng::below(n) is in [0, n) and covers it", "[core][rng]") {
  Rng rng(21);
  for (std::uint64_t n :
       {1ull, 2ull, 3ull, 7ull, 10ull, 1000ull, (1ull << 63) + 1, 0xffffffffffffffffull}) {
    for (int i = 0; i < 2000; ++i) REQUIRE(rng.below(n) < n);
  }
  CHECK(rng.below(1) == 0);
  // Every value of a small range appears, with roughly equal frequency.
  std::vector<int> counts(6, 0);
  const int draws = 60000;
  for (int i = 0; i < draws; ++i) ++counts[static_cast<std::size_t>(rng.below(6))];
  for (int c : counts) CHECK(c == Approx(draws / 6.0).epsilon(0.05));
  CHECK_THROWS_WITH(rng.below(0), Catch::Matchers::Contains("got 0"));
}

TEST_CASE("Rng::uniform_int is inclusive", "[core][rng]") {
  Rng rng(4);
  std::set<std::int64_t> seen;
  for (int i = 0; i < 2000; ++i) {
    const auto x = rng.uniform_int(-2, 2);
    REQUIRE(x >= -2);
    REQUIRE(x <= 2);
    seen.insert(x);
  }
  CHECK(seen.size() == 5);
  CHECK(rng.uniform_int(9, 9) == 9);
  CHECK_THROWS_AS(rng.uniform_int(3, 2), gimm::Error);
  // Ranges wider than INT64_MAX (hi - lo overflows std::int64_t) stay in bounds, and the full
  // 64-bit range is the raw stream.
  constexpr auto min64 = std::numeric_limits<std::int64_t>::min();
  constexpr auto max64 = std::numeric_limits<std::int64_t>::max();
  Rng wide(5), raw(5);
  for (int i = 0; i < 1000; ++i)
    REQUIRE(wide.uniform_int(min64, max64) == static_cast<std::int64_t>(raw.next_u64()));
  bool saw_negative = false, saw_positive = false;
  for (int i = 0; i < 1000; ++i) {
    const auto x = wide.uniform_int(-3, max64);
    REQUIRE(x >= -3);
    const auto y = wide.uniform_int(min64, 3);
    REQUIRE(y <= 3);
    const auto z = wide.uniform_int(min64 / 2 - 5, max64 / 2 + 5);
    REQUIRE(z >= min64 / 2 - 5);
    REQUIRE(z <= max64 / 2 + 5);
    saw_negative = saw_negative || z < 0;
    saw_positive = saw_positive || z > 0;
  }
  CHECK(saw_negative);
  CHECK(saw_positive);
  CHECK(wide.uniform_int(max64, max64) == max64);
  CHECK(wide.uniform_int(min64, min64) == min64);
}

TEST_CASE("Rng::normal has mean 0 and variance 1", "[core][rng]") {
  Rng rng(13);
  const int n = 200000;
  double sum = 0, sum2 = 0;
  for (int i = 0; i < n; ++i) {
    const double x = rng.normal();
    REQUIRE(std::isfinite(x));
    sum += x;
    sum2 += x * x;
  }
  CHECK(sum / n == Approx(0).margin(0.01));
  CHECK(sum2 / n == Approx(1).epsilon(0.01));
  Rng a(1), b(1);
  CHECK(a.normal(10.0, 0.5) == Approx(10.0 + 0.5 * b.normal()));
  CHECK(a.normal(3.0, 0.0) == 3.0);
  CHECK_THROWS_AS(a.normal(0.0, -1.0), gimm::Error);
  CHECK_THROWS_AS(a.normal(0.0, std::nan("")), gimm::Error);
}

TEST_CASE("Rng::fork gives distinct, reproducible sub-streams", "[core][rng]") {
  const Rng parent(2024);
  // Reproducible: same parent state and index, same stream; independent of fork order.
  Rng a1 = parent.fork(3);
  Rng b = parent.fork(4);
  Rng a2 = parent.fork(3);
  (void)b;
  for (int i = 0; i < 16; ++i) CHECK(a1.next_u64() == a2.next_u64());

  // Different indices, and the parent itself, give different streams.
  std::set<std::uint64_t> firsts;
  Rng copy = parent;
  firsts.insert(copy.next_u64());
  for (std::uint64_t index = 0; index < 100; ++index) firsts.insert(parent.fork(index).next_u64());
  CHECK(firsts.size() == 101);

  // Forking does not advance the parent.
  Rng p1(2024), p2(2024);
  (void)p1.fork(0);
  CHECK(p1.next_u64() == p2.next_u64());

  // Different parents give different children for the same index.
  CHECK(Rng(1).fork(0).next_u64() != Rng(2).fork(0).next_u64());
}
