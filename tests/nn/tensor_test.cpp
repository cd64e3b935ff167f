// nn::Tensor: row-major shapes and strides, checked element access, reshape, and shape checks
// whose messages name the tensor.
#include <catch2/catch.hpp>
#include <cstdint>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/nn/tensor.hpp"

using Catch::Contains;
using gimm::nn::Shape;
using gimm::nn::Tensor;

TEST_CASE("Tensor: shape, row-major strides and element order", "[nn][tensor]") {
  Tensor t({2, 3, 4});
  CHECK(t.rank() == 3);
  CHECK(t.shape() == Shape{2, 3, 4});
  CHECK(t.strides() == Shape{12, 4, 1});
  CHECK(t.numel() == 24);
  CHECK_FALSE(t.empty());
  CHECK(t.dim(0) == 2);
  CHECK(t.dim(2) == 4);
  CHECK(t.dim(-1) == 4);
  CHECK(t.dim(-3) == 2);
  for (float v : t.values()) CHECK(v == 0.0f);  // zero-filled

  // at(n, c, x) addresses the flat index n*12 + c*4 + x: the last axis is the fastest.
  for (std::int64_t i = 0; i < t.numel(); ++i) t[i] = float(i);
  CHECK(t.at(0, 0, 1) == 1.0f);
  CHECK(t.at(0, 1, 0) == 4.0f);
  CHECK(t.at(1, 0, 0) == 12.0f);
  CHECK(t.at(1, 2, 3) == 23.0f);
  t.at(1, 1, 2) = -5.0f;
  CHECK(t[12 + 4 + 2] == -5.0f);
  const Tensor& ct = t;
  CHECK(ct.at(1, 1, 2) == -5.0f);

  CHECK(Tensor({5}).strides() == Shape{1});
  CHECK(Tensor({2, 1, 3, 5}).strides() == Shape{15, 15, 5, 1});
  CHECK(Tensor(Shape{2, 2}, 1.5f).values() == std::vector<float>(4, 1.5f));

  const Tensor empty;
  CHECK(empty.rank() == 0);
  CHECK(empty.numel() == 0);
  CHECK(empty.empty());
  const Tensor zero_extent({3, 0, 2});
  CHECK(zero_extent.numel() == 0);
  CHECK(zero_extent.strides() == Shape{0, 2, 1});
}

TEST_CASE("Tensor: from data, and construction errors", "[nn][tensor]") {
  const Tensor t({2, 3}, std::vector<float>{1, 2, 3, 4, 5, 6});
  CHECK(t.at(1, 0) == 4.0f);
  CHECK(t.at(0, 2) == 3.0f);
  REQUIRE_THROWS_AS(Tensor({2, 3}, std::vector<float>(5)), gimm::Error);
  REQUIRE_THROWS_WITH(Tensor({2, 3}, std::vector<float>(7)),
                      Contains("7 values do not fill shape [2, 3]"));
  REQUIRE_THROWS_WITH(Tensor({2, -1}), Contains("negative extent in shape [2, -1]"));
  REQUIRE_THROWS_WITH(Tensor({1 << 21, 1 << 21}), Contains("too large"));
  // No element, yet strides past int64: refused as well.
  REQUIRE_THROWS_WITH(Tensor({0, std::int64_t{1} << 62, std::int64_t{1} << 62}),
                      Contains("too large"));
  CHECK(gimm::nn::shape_string({2, 64, 32, 32}) == "[2, 64, 32, 32]");
  CHECK(gimm::nn::shape_string({}) == "[]");
  CHECK(gimm::nn::shape_numel({}) == 1);
  CHECK(gimm::nn::shape_numel({4, 0, 3}) == 0);
}

TEST_CASE("Tensor: at() and dim() bounds errors", "[nn][tensor]") {
  Tensor t({2, 3, 4});
  const Tensor& ct = t;
  REQUIRE_THROWS_WITH(t.at(2, 0, 0), Contains("index 2 out of range on axis 0 of shape [2, 3, 4]"));
  REQUIRE_THROWS_WITH(t.at(0, 3, 0), Contains("index 3 out of range on axis 1"));
  REQUIRE_THROWS_WITH(t.at(0, 0, 4), Contains("index 4 out of range on axis 2"));
  REQUIRE_THROWS_WITH(ct.at(0, -1, 0), Contains("index -1 out of range on axis 1"));
  REQUIRE_THROWS_WITH(t.at(0, 0), Contains("2 indices for shape [2, 3, 4]"));
  REQUIRE_THROWS_WITH(ct.at(0, 0, 0, 0), Contains("4 indices for shape [2, 3, 4]"));
  REQUIRE_NOTHROW(t.at(1, 2, 3));
  REQUIRE_THROWS_WITH(t.dim(3), Contains("axis 3 out of range for shape [2, 3, 4]"));
  REQUIRE_THROWS_WITH(t.dim(-4), Contains("axis -4 out of range"));
}

TEST_CASE("Tensor: reshape keeps the data and checks the element count", "[nn][tensor]") {
  Tensor t({2, 3, 4});
  for (std::int64_t i = 0; i < t.numel(); ++i) t[i] = float(i);
  const Tensor r = t.reshaped({6, 4});
  CHECK(r.shape() == Shape{6, 4});
  CHECK(r.strides() == Shape{4, 1});
  CHECK(r.values() == t.values());
  CHECK(r.at(5, 3) == 23.0f);
  CHECK(t.shape() == Shape{2, 3, 4});  // the lvalue overload copies

  Tensor moved = std::move(t).reshaped({24});
  CHECK(moved.shape() == Shape{24});
  CHECK(moved.strides() == Shape{1});
  CHECK(moved.at(17) == 17.0f);

  const Tensor source({2, 3});
  REQUIRE_THROWS_WITH(source.reshaped({4, 2}), Contains("cannot reshape [2, 3] to [4, 2]"));
  REQUIRE_THROWS_AS(Tensor({2, 3}).reshaped({7}), gimm::Error);
  REQUIRE_THROWS_WITH(source.reshaped({5}), Contains("cannot reshape [2, 3] to [5]"));
  REQUIRE_THROWS_AS(Tensor({2, 3}).reshaped({1, 5}), gimm::Error);
  REQUIRE_THROWS_AS(source.reshaped({-2, -3}), gimm::Error);
}

TEST_CASE("Tensor: expect_shape and expect_rank name the tensor", "[nn][tensor]") {
  const Tensor t({2, 5});
  REQUIRE_NOTHROW(t.expect_shape({2, 5}, "weights"));
  REQUIRE_NOTHROW(t.expect_rank(2, "weights"));
  REQUIRE_THROWS_WITH(t.expect_shape({5, 2}, "layer3.conv1.weight"),
                      Contains("layer3.conv1.weight: expected shape [5, 2], got [2, 5]"));
  REQUIRE_THROWS_WITH(t.expect_shape({2, 5, 1}, "bias"), Contains("bias: expected shape"));
  REQUIRE_THROWS_WITH(t.expect_rank(4, "stem input"),
                      Contains("stem input: expected a rank-4 tensor, got shape [2, 5]"));
  // Every message carries the library prefix.
  REQUIRE_THROWS_WITH(t.expect_rank(3, "x"), Catch::StartsWith("gimm: "));
}
