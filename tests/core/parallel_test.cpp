// parallel_for / parallel_for_dynamic: every index exactly once, exceptions rethrown on the
// calling thread, results independent of the thread count with Rng::fork.
#include <atomic>
#include <catch2/catch.hpp>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/core/parallel.hpp"
#include "gimm/core/rng.hpp"

#ifdef _OPENMP
#include <omp.h>
#endif

using namespace gimm;

namespace {

std::vector<std::uint64_t> forked_draws(std::int64_t n) {
  std::vector<std::uint64_t> out(static_cast<std::size_t>(n));
  const Rng root(77);
  parallel_for(0, n, [&](std::int64_t i) {
    Rng rng = root.fork(static_cast<std::uint64_t>(i));
    out[static_cast<std::size_t>(i)] = rng.next_u64() ^ rng.below(1000);
  });
  return out;
}

}  // namespace

TEST_CASE("parallel_for visits every index exactly once", "[core][parallel]") {
  CHECK(max_threads() >= 1);
  for (std::int64_t begin : {std::int64_t{0}, std::int64_t{-13}, std::int64_t{1000}}) {
    for (std::int64_t count : {0, 1, 2, 3, 17, 1001}) {
      const std::int64_t end = begin + count;
      std::vector<std::atomic<int>> hits(static_cast<std::size_t>(count));
      for (auto& h : hits) h = 0;
      std::atomic<std::int64_t> out_of_range{0};
      parallel_for(begin, end, [&](std::int64_t i) {
        if (i < begin || i >= end) {
          ++out_of_range;
          return;
        }
        ++hits[static_cast<std::size_t>(i - begin)];
      });
      CHECK(out_of_range == 0);
      for (const auto& h : hits) CHECK(h == 1);
    }
  }
  // An empty or reversed range runs nothing.
  int calls = 0;
  parallel_for(5, 5, [&](std::int64_t) { ++calls; });
  parallel_for(5, 2, [&](std::int64_t) { ++calls; });
  CHECK(calls == 0);
}

TEST_CASE("parallel_for below serial_below runs in order on the calling thread",
          "[core][parallel]") {
  std::vector<std::int64_t> order;  // not thread-safe on purpose: must be serial
  parallel_for(
      3, 10, [&](std::int64_t i) { order.push_back(i); }, 100);
  CHECK(order == std::vector<std::int64_t>{3, 4, 5, 6, 7, 8, 9});
}

TEST_CASE("parallel_for_dynamic visits every index exactly once", "[core][parallel]") {
  for (std::int64_t chunk : {1, 3, 64}) {
    const std::int64_t n = 777;
    std::vector<std::atomic<int>> hits(static_cast<std::size_t>(n));
    for (auto& h : hits) h = 0;
    parallel_for_dynamic(0, n, chunk, [&](std::int64_t i) { ++hits[static_cast<std::size_t>(i)]; });
    for (const auto& h : hits) CHECK(h == 1);
  }
}

TEST_CASE("parallel_for rethrows an exception from the body", "[core][parallel]") {
  std::atomic<int> ran{0};
  REQUIRE_THROWS_AS(parallel_for(0, 1000,
                                 [&](std::int64_t i) {
                                   ++ran;
                                   GIMM_CHECK(i != 537, "bad item " << i);
                                 }),
                    Error);
  // The loop is not abandoned: the other iterations still ran.
  CHECK(ran == 1000);
  REQUIRE_THROWS_WITH(parallel_for(0, 1000,
                                   [&](std::int64_t i) {
                                     if (i == 537) throw std::out_of_range("item 537");
                                   }),
                      "item 537");
  REQUIRE_THROWS_AS(parallel_for(0, 1000,
                                 [&](std::int64_t i) {
                                   if (i == 3) throw std::out_of_range("item 3");
                                 }),
                    std::out_of_range);
  // Serial path too.
  REQUIRE_THROWS_AS(parallel_for(0, 1, [&](std::int64_t) { throw std::logic_error("one"); }),
                    std::logic_error);
  // Every iteration throwing: exactly one exception reaches the caller.
  REQUIRE_THROWS_AS(parallel_for(0, 64, [&](std::int64_t) { throw std::runtime_error("all"); }),
                    std::runtime_error);
}

TEST_CASE("parallel_for_dynamic rethrows an exception from the body", "[core][parallel]") {
  REQUIRE_THROWS_WITH(
      parallel_for_dynamic(0, 500, 7,
                           [&](std::int64_t i) { GIMM_CHECK(i != 250, "bad item " << i); }),
      "gimm: bad item 250");
}

TEST_CASE("parallel_for with Rng::fork is independent of the thread count", "[core][parallel]") {
  const auto reference = forked_draws(5000);
#ifdef _OPENMP
  const int saved = omp_get_max_threads();
  for (int threads : {1, 2, 3, 8}) {
    omp_set_num_threads(threads);
    CHECK(forked_draws(5000) == reference);
  }
  omp_set_num_threads(saved);
#else
  CHECK(forked_draws(5000) == reference);
#endif
}
