// The engine keeps its activations' storage between pairs (nn/tensor_pool.hpp): a tensor's
// buffer is reused by the next tensor that fits, a reused tensor is filled as a fresh one is,
// small buffers and buffers past the limit are not kept.
#include <catch2/catch.hpp>

#include "gimm/nn/tensor.hpp"

using gimm::nn::Tensor;
using gimm::nn::TensorPool;

TEST_CASE("Tensor pool: a freed activation's storage serves the next one that fits", "[nn]") {
  TensorPool& pool = TensorPool::instance();
  pool.release();
  const float* first = nullptr;
  {
    Tensor a({1, 8, 64, 64}, 3.0f);
    first = a.data();
  }
  CHECK(pool.bytes() >= 8 * 64 * 64 * sizeof(float));
  Tensor b({1, 8, 64, 60});  // a little smaller: the same storage, filled with zeros
  CHECK(b.data() == first);
  CHECK(b.numel() == 8 * 64 * 60);
  for (std::int64_t i = 0; i < b.numel(); ++i) REQUIRE(b[i] == 0.0f);
  CHECK(pool.bytes() == 0);
  // Less than half the kept size: not that storage (it would waste more than it saves).
  { Tensor big({1, 64, 64, 64}); }
  const std::size_t kept = pool.bytes();
  Tensor small({1, 8, 64, 64});
  CHECK(pool.bytes() == kept);
  // A move assignment keeps the storage it replaces.
  pool.release();
  Tensor c({1, 8, 64, 64});
  const float* c_storage = c.data();
  c = Tensor({1, 16, 64, 64});
  CHECK(pool.bytes() >= 8 * 64 * 64 * sizeof(float));
  CHECK(Tensor({1, 8, 64, 64}).data() == c_storage);
}

TEST_CASE("Tensor pool: small buffers and buffers past the limit go to the allocator", "[nn]") {
  TensorPool& pool = TensorPool::instance();
  pool.release();
  { Tensor tiny({1, 4, 8, 8}); }  // 1 KB
  CHECK(pool.bytes() == 0);
  pool.set_limit_bytes(0);
  { Tensor a({1, 8, 64, 64}); }
  CHECK(pool.bytes() == 0);
  pool.set_limit_bytes(std::size_t{1} << 20);  // 1 MB: one 512 KB buffer, not three
  { Tensor a({1, 32, 64, 64}), b({1, 32, 64, 64}), c({1, 32, 64, 64}); }
  CHECK(pool.bytes() <= std::size_t{1} << 20);
  CHECK(pool.bytes() >= 32 * 64 * 64 * sizeof(float));
  pool.set_limit_bytes(std::size_t{256} << 20);
  pool.release();
  CHECK(pool.bytes() == 0);
}

TEST_CASE("Tensor pool: activations on huge pages are not kept", "[nn]") {
  TensorPool& pool = TensorPool::instance();
  pool.release();
  { Tensor huge({1, 64, 256, 128}); }  // 8 MB: on huge pages, where faults are few
  CHECK(pool.bytes() == 0);
  { Tensor below({1, 63, 256, 128}); }
  CHECK(pool.bytes() > 0);
  pool.release();
}
