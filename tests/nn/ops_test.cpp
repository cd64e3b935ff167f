// nn ops: every fast path against its reference over grids of shapes, and every reference
// against a hand computation or PyTorch numbers, so that a flipped convention fails:
// conv2d (cross-correlation, weight layout, padding side, bands), fold_batch_norm, linear,
// layer_norm, embedding, linear attention (elu feature map, heads), softmax / dual softmax,
// soft_argmax (x along columns), upsample_bilinear (align_corners=True), extract_windows and
// the sine positional encoding.
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/core/rng.hpp"
#include "gimm/nn/activations.hpp"
#include "gimm/nn/attention.hpp"
#include "gimm/nn/conv2d.hpp"
#if __has_include("gimm/nn/fast_exp.hpp")
#include "gimm/nn/fast_exp.hpp"
#endif
#include "gimm/nn/linear.hpp"
#include "gimm/nn/positional_encoding.hpp"
#include "gimm/nn/resample.hpp"
#include "gimm/nn/softmax.hpp"
#include "gimm/nn/tensor.hpp"

#ifdef _OPENMP
#include <omp.h>
#endif

using namespace gimm::nn;
using Catch::Contains;

namespace {

Tensor random_tensor(Shape shape, std::uint64_t seed, double lo = -1.0, double hi = 1.0) {
  Tensor t(std::move(shape));
  gimm::Rng rng(seed);
  for (float& v : t.values()) v = float(rng.uniform(lo, hi));
  return t;
}

/// max |a - b| / max |b|: the error relative to the reference's scale (no blow-up near zeros).
double rel_error(const Tensor& a, const Tensor& b) {
  REQUIRE(a.shape() == b.shape());
  double diff = 0, scale = 0;
  for (std::int64_t i = 0; i < a.numel(); ++i) {
    diff = std::max(diff, std::abs(double(a[i]) - double(b[i])));
    scale = std::max(scale, std::abs(double(b[i])));
  }
  return scale > 0 ? diff / scale : diff;
}

double max_abs_diff(const Tensor& a, const Tensor& b) {
  REQUIRE(a.shape() == b.shape());
  double diff = 0;
  for (std::int64_t i = 0; i < a.numel(); ++i)
    diff = std::max(diff, std::abs(double(a[i]) - double(b[i])));
  return diff;
}

Conv2d make_conv(std::int64_t cout, std::int64_t cin, std::int64_t k, int stride, int padding,
                 std::uint64_t seed, bool with_bias = true) {
  const Tensor bias = random_tensor({cout}, seed + 1);
  return Conv2d::from(random_tensor({cout, cin, k, k}, seed), with_bias ? &bias : nullptr, stride,
                      padding, "test_conv");
}

std::int64_t out_size(std::int64_t in, std::int64_t k, int s, int p) {
  return (in + 2 * p - k) / s + 1;
}

/// Runs `body` with the OpenMP thread count set to `threads`, then restores it.
template <class F>
auto with_threads(int threads, F&& body) {
#ifdef _OPENMP
  const int saved = omp_get_max_threads();
  omp_set_num_threads(threads);
  auto result = body();
  omp_set_num_threads(saved);
  return result;
#else
  (void)threads;
  return body();
#endif
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// conv2d

TEST_CASE("conv2d: hand-computed 3x3 input, 2x2 kernel (cross-correlation)", "[nn][conv2d]") {
  // x = [[1 2 3] [4 5 6] [7 8 9]], w = [[1 2] [3 4]].
  const Tensor x({1, 1, 3, 3}, std::vector<float>{1, 2, 3, 4, 5, 6, 7, 8, 9});
  const Tensor w({1, 1, 2, 2}, std::vector<float>{1, 2, 3, 4});
  const Tensor flipped({1, 1, 2, 2}, std::vector<float>{4, 3, 2, 1});

  SECTION("stride 1, no padding") {
    const Conv2d conv = Conv2d::from(w, nullptr, 1, 0, "c");
    // out[0,0] = 1*1 + 2*2 + 3*4 + 4*5: the kernel is not flipped.
    const std::vector<float> expected{37, 47, 67, 77};
    for (const Tensor& out : {conv2d_reference(x, conv), conv2d(x, conv)}) {
      CHECK(out.shape() == Shape{1, 1, 2, 2});
      CHECK(out.values() == expected);
    }
    // True convolution (a flipped kernel) gives other numbers.
    const Conv2d conv_flipped = Conv2d::from(flipped, nullptr, 1, 0, "c");
    CHECK(conv2d(x, conv_flipped).values() != expected);
    CHECK(conv2d(x, conv_flipped).values() == std::vector<float>{23, 33, 53, 63});
  }
  SECTION("padding 1 pads with zeros on every side, bias is added") {
    const Tensor bias({1}, std::vector<float>{0.5f});
    const Conv2d conv = Conv2d::from(w, &bias, 1, 1, "c");
    // out[y, x] = b + sum w[ky, kx] in[y - 1 + ky, x - 1 + kx].
    // (torch.nn.functional.conv2d gives the same.)
    const std::vector<float> expected{4,  11, 18, 9,   //
                                      18, 37, 47, 21,  //
                                      36, 67, 77, 33,  //
                                      14, 23, 26, 9};
    for (const Tensor& out : {conv2d_reference(x, conv), conv2d(x, conv)}) {
      REQUIRE(out.shape() == Shape{1, 1, 4, 4});
      for (std::size_t i = 0; i < expected.size(); ++i)
        CHECK(out.values()[i] == expected[i] + 0.5f);
    }
  }
  SECTION("stride 2, padding 1") {
    const Conv2d conv = Conv2d::from(w, nullptr, 2, 1, "c");
    // Output (y, x) reads input rows 2y - 1 + ky and columns 2x - 1 + kx.
    const std::vector<float> expected{4, 18, 36, 77};
    for (const Tensor& out : {conv2d_reference(x, conv), conv2d(x, conv)}) {
      CHECK(out.shape() == Shape{1, 1, 2, 2});
      CHECK(out.values() == expected);
    }
  }
}

TEST_CASE("conv2d: weight layout is [Cout, Cin, K, K]", "[nn][conv2d]") {
  // 2 input channels (constant 1 and 2), 2 output channels; w[o, c] = {{1, 10}, {100, 1000}}.
  Tensor x({1, 2, 3, 5});
  for (std::int64_t i = 0; i < 15; ++i) {
    x[i] = 1.0f;
    x[15 + i] = 2.0f;
  }
  for (int k : {1, 3}) {
    Tensor w({2, 2, k, k});
    const int centre = k / 2;
    w.at(0, 0, centre, centre) = 1;
    w.at(0, 1, centre, centre) = 10;
    w.at(1, 0, centre, centre) = 100;
    w.at(1, 1, centre, centre) = 1000;
    const Conv2d conv = Conv2d::from(w, nullptr, 1, k / 2, "c");
    for (const Tensor& out : {conv2d_reference(x, conv), conv2d(x, conv)}) {
      INFO("kernel " << k);
      REQUIRE(out.shape() == Shape{1, 2, 3, 5});
      for (std::int64_t y = 0; y < 3; ++y)
        for (std::int64_t xx = 0; xx < 5; ++xx) {
          CHECK(out.at(0, 0, y, xx) == 21.0f);    // 1*1 + 10*2
          CHECK(out.at(0, 1, y, xx) == 2100.0f);  // 100*1 + 1000*2
        }
    }
  }
}

TEST_CASE("conv2d: epilogue adds bias and residual before the ReLU", "[nn][conv2d]") {
  const Tensor x({1, 1, 2, 2}, std::vector<float>{1, 1, 1, 1});
  const Tensor w({2, 1, 1, 1}, std::vector<float>{0, 0});
  const Tensor bias({2}, std::vector<float>{-1, -3});
  const Tensor residual({1, 2, 2, 2}, std::vector<float>{3, 0, 0.5f, 1, 1, 4, 2, 3});
  for (int padding : {0, 1}) {  // 1x1 stride 1 pad 0 is the pointwise path; pad 1 is im2col
    const Conv2d conv = Conv2d::from(w, &bias, 1, padding, "c");
    const Tensor res = padding == 0 ? residual : Tensor({1, 2, 4, 4}, 1.0f);
    for (bool fast : {false, true}) {
      INFO("padding " << padding << " fast " << fast);
      const Tensor plain = fast ? conv2d(x, conv, Activation::none, &res)
                                : conv2d_reference(x, conv, Activation::none, &res);
      const Tensor relu = fast ? conv2d(x, conv, Activation::relu, &res)
                               : conv2d_reference(x, conv, Activation::relu, &res);
      for (std::int64_t i = 0; i < plain.numel(); ++i) {
        const float expected = (i < plain.numel() / 2 ? -1.0f : -3.0f) + res[i];
        CHECK(plain[i] == expected);
        CHECK(relu[i] == std::max(expected, 0.0f));
      }
    }
  }
}

TEST_CASE("conv2d: fast path equals the reference over a grid of shapes", "[nn][conv2d]") {
  std::uint64_t seed = 100;
  int cases = 0;
  for (int k : {1, 3, 7})
    for (int stride : {1, 2})
      for (int padding : {0, 1, 3})
        for (int variant = 0; variant < 2; ++variant) {
          const std::int64_t n = 2, cin = variant ? 5 : 3, cout = variant ? 7 : 11;
          const std::int64_t h = 13, w = variant ? 11 : 9;
          const Conv2d conv = make_conv(cout, cin, k, stride, padding, seed++, variant == 0);
          const Tensor x = random_tensor({n, cin, h, w}, seed++);
          const Tensor residual = random_tensor(
              {n, cout, out_size(h, k, stride, padding), out_size(w, k, stride, padding)}, seed++);
          const Activation act = variant ? Activation::relu : Activation::none;
          INFO("k " << k << " stride " << stride << " padding " << padding << " variant "
                    << variant);
          const Tensor ref = conv2d_reference(x, conv, act, &residual);
          const Tensor fast = conv2d(x, conv, act, &residual);
          REQUIRE(fast.shape() == ref.shape());
          CHECK(rel_error(fast, ref) < 1e-5);
          // Without the residual and activation too.
          CHECK(rel_error(conv2d(x, conv), conv2d_reference(x, conv)) < 1e-5);
          ++cases;
        }
  CHECK(cases == 36);
}

TEST_CASE("conv2d: fast path equals the reference at the edges", "[nn][conv2d]") {
  // Tiny inputs, stride 3, padding wider than the kernel reach: im2col columns that are all
  // padding, or whose valid range is empty or a single pixel.
  std::uint64_t seed = 900;
  int cases = 0;
  for (std::int64_t size : {1, 2, 5, 8})
    for (int k : {1, 2, 3, 5})
      for (int stride : {1, 2, 3})
        for (int padding : {0, 1, 2, 4}) {
          const std::int64_t h = size, w = size + 1;
          if (h + 2 * padding < k) continue;
          const Conv2d conv = make_conv(3, 2, k, stride, padding, seed++);
          const Tensor x = random_tensor({2, 2, h, w}, seed++);
          INFO("size " << h << "x" << w << " k " << k << " stride " << stride << " padding "
                       << padding);
          const Tensor ref = conv2d_reference(x, conv, Activation::relu);
          const Tensor fast = conv2d(x, conv, Activation::relu);
          REQUIRE(fast.shape() == ref.shape());
          CHECK(ref.dim(2) == out_size(h, k, stride, padding));
          CHECK(ref.dim(3) == out_size(w, k, stride, padding));
          CHECK(rel_error(fast, ref) < 1e-5);
          ++cases;
        }
  CHECK(cases > 150);
}

TEST_CASE("conv2d: fast path across several row bands", "[nn][conv2d]") {
  struct Case {
    std::int64_t cin, cout, k, h, w;
    int stride, padding;
  };
  // 3x3 Cin 64 at 70x90: a band is 2 output rows (35 bands); the stride-2 case has a partial
  // last band (36 rows in bands of 9 at 46 columns); the 1x1 case takes the pointwise path
  // (bands of 22 rows, the last one 4).
  for (const Case& c : {Case{64, 13, 3, 70, 90, 1, 1}, Case{32, 9, 3, 71, 91, 2, 1},
                        Case{64, 10, 1, 70, 90, 1, 0}}) {
    INFO("cin " << c.cin << " k " << c.k << " stride " << c.stride);
    const Conv2d conv = make_conv(c.cout, c.cin, c.k, c.stride, c.padding, 7 + c.cin);
    const Tensor x = random_tensor({2, c.cin, c.h, c.w}, 8 + c.cin);
    const Tensor residual = random_tensor({2, c.cout, out_size(c.h, c.k, c.stride, c.padding),
                                           out_size(c.w, c.k, c.stride, c.padding)},
                                          9 + c.cin);
    const Tensor ref = conv2d_reference(x, conv, Activation::relu, &residual);
    const Tensor fast = conv2d(x, conv, Activation::relu, &residual);
    CHECK(rel_error(fast, ref) < 1e-5);
    // Every output row band agrees, not only the overall maximum: check per row.
    const std::int64_t ho = ref.dim(2), wo = ref.dim(3);
    double worst_row = 0;
    for (std::int64_t b = 0; b < 2; ++b)
      for (std::int64_t o = 0; o < c.cout; ++o)
        for (std::int64_t y = 0; y < ho; ++y)
          for (std::int64_t xx = 0; xx < wo; ++xx)
            worst_row =
                std::max(worst_row, double(std::abs(fast.at(b, o, y, xx) - ref.at(b, o, y, xx))));
    CHECK(worst_row < 1e-4);
    // The band split is fixed, so one thread and all threads give identical bits.
    const Tensor one =
        with_threads(1, [&] { return conv2d(x, conv, Activation::relu, &residual); });
    CHECK(one.values() == fast.values());
  }
}

TEST_CASE("conv2d: fold_batch_norm equals conv then the BN formula", "[nn][conv2d]") {
  const std::int64_t cout = 6, cin = 5;
  for (bool with_bias : {true, false}) {
    INFO("bias " << with_bias);
    Conv2d conv = make_conv(cout, cin, 3, 1, 1, 41, with_bias);
    const Tensor x = random_tensor({2, cin, 9, 7}, 42);
    const Tensor gamma = random_tensor({cout}, 43, 0.5, 2.0);
    const Tensor beta = random_tensor({cout}, 44);
    const Tensor mean = random_tensor({cout}, 45);
    const Tensor var = random_tensor({cout}, 46, 0.0, 3.0);
    const float eps = 1e-3f;  // large enough that dropping it would show
    const Tensor plain = conv2d_reference(x, conv);
    fold_batch_norm(conv, gamma, beta, mean, var, eps, "bn1");
    const Tensor folded_ref = conv2d_reference(x, conv);
    const Tensor folded = conv2d(x, conv);
    Tensor expected(plain.shape());
    for (std::int64_t b = 0; b < 2; ++b)
      for (std::int64_t o = 0; o < cout; ++o)
        for (std::int64_t y = 0; y < 9; ++y)
          for (std::int64_t xx = 0; xx < 7; ++xx)
            expected.at(b, o, y, xx) =
                float(double(gamma[o]) * (plain.at(b, o, y, xx) - double(mean[o])) /
                          std::sqrt(double(var[o]) + double(eps)) +
                      beta[o]);
    CHECK(rel_error(folded_ref, expected) < 1e-5);
    CHECK(rel_error(folded, expected) < 1e-5);
  }
  SECTION("errors") {
    Conv2d conv = make_conv(cout, cin, 3, 1, 1, 47);
    const Tensor ok({cout}, 1.0f), wrong({cout + 1}, 1.0f), negative({cout}, -1.0f);
    REQUIRE_THROWS_WITH(fold_batch_norm(conv, wrong, ok, ok, ok, 1e-5f, "layer1.bn"),
                        Contains("layer1.bn: expected shape [6], got [7]"));
    REQUIRE_THROWS_WITH(fold_batch_norm(conv, ok, ok, ok, wrong, 1e-5f, "layer1.bn"),
                        Contains("layer1.bn"));
    REQUIRE_THROWS_WITH(fold_batch_norm(conv, ok, ok, ok, negative, 1e-5f, "bn2"),
                        Contains("bn2: running_var[0] = -1 is not a variance"));
  }
}

TEST_CASE("conv2d: input and layer errors", "[nn][conv2d]") {
  const Conv2d conv = make_conv(4, 3, 3, 1, 0, 51);
  const Tensor wrong_channels({1, 5, 8, 8});
  for (bool fast : {false, true}) {
    auto run = [&](const Tensor& x, const Tensor* residual = nullptr) {
      return fast ? conv2d(x, conv, Activation::none, residual)
                  : conv2d_reference(x, conv, Activation::none, residual);
    };
    REQUIRE_THROWS_WITH(run(wrong_channels), Contains("input has 5 channels, the layer expects 3"));
    REQUIRE_THROWS_WITH(run(Tensor({3, 8, 8})),
                        Contains("conv2d input: expected a rank-4 tensor, got shape [3, 8, 8]"));
    REQUIRE_THROWS_WITH(run(Tensor({1, 3, 2, 8})), Contains("smaller than the kernel"));
    const Tensor bad_residual({1, 4, 8, 8});  // the output is 6x6
    REQUIRE_THROWS_WITH(run(Tensor({1, 3, 8, 8}), &bad_residual),
                        Contains("conv2d residual: expected shape [1, 4, 6, 6]"));
    REQUIRE_NOTHROW(run(Tensor({1, 3, 3, 3})));
  }
  REQUIRE_THROWS_WITH(Conv2d::from(Tensor({4, 3, 3, 2}), nullptr, 1, 0, "stem"),
                      Contains("stem: conv weight must be [Cout, Cin, K, K], got [4, 3, 3, 2]"));
  REQUIRE_THROWS_WITH(Conv2d::from(Tensor({4, 3, 3}), nullptr, 1, 0, "stem"),
                      Contains("stem: conv weight"));
  REQUIRE_THROWS_WITH(Conv2d::from(Tensor({4, 3, 3, 3}), nullptr, 0, 0, "stem"),
                      Contains("stem: bad stride 0"));
  REQUIRE_THROWS_WITH(Conv2d::from(Tensor({4, 3, 3, 3}), nullptr, 1, -1, "stem"),
                      Contains("padding -1"));
  const Tensor bad_bias({3});
  REQUIRE_THROWS_WITH(Conv2d::from(Tensor({4, 3, 3, 3}), &bad_bias, 1, 0, "stem"),
                      Contains("stem.bias: expected shape [4], got [3]"));
  const Conv2d no_bias = Conv2d::from(Tensor({4, 3, 3, 3}), nullptr, 1, 0, "stem");
  CHECK(no_bias.bias == std::vector<float>(4, 0.0f));
  CHECK(no_bias.out_channels() == 4);
  CHECK(no_bias.in_channels() == 3);
  CHECK(no_bias.kernel() == 3);
}

// ---------------------------------------------------------------------------------------------
// linear, layer norm, embedding

TEST_CASE("linear: y = x W^T + b, W stored [out, in]", "[nn][linear]") {
  const Tensor w({2, 2}, std::vector<float>{1, 2, 3, 4});
  const Tensor b({2}, std::vector<float>{0.5f, -100});
  const Linear layer = Linear::from(w, &b, "fc");
  const Tensor x({1, 2}, std::vector<float>{1, 10});
  // [1*1 + 2*10 + 0.5, 3*1 + 4*10 - 100]; x W (no transpose) would be [31, 42].
  for (const Tensor& y : {linear_reference(x, layer), linear(x, layer)})
    CHECK(y.values() == std::vector<float>{21.5f, -57.0f});
  CHECK(linear(x, layer, true).values() == std::vector<float>{21.5f, 0.0f});

  const Linear wide =
      Linear::from(Tensor({3, 2}, std::vector<float>{1, 0, 0, 1, 1, 1}), nullptr, "fc2");
  CHECK(wide.in_features() == 2);
  CHECK(wide.out_features() == 3);
  CHECK(wide.bias == std::vector<float>(3, 0.0f));
  const Tensor y = linear(Tensor({2, 1, 2}, std::vector<float>{2, 5, -1, 3}), wide);
  CHECK(y.shape() == Shape{2, 1, 3});
  CHECK(y.values() == std::vector<float>{2, 5, 7, -1, 3, 2});
}

TEST_CASE("linear: fast path equals the reference", "[nn][linear]") {
  struct Case {
    Shape x;
    std::int64_t out;
    bool bias;
  };
  // [3, 200, 19] is 600 rows: three 256-row blocks, the last partial.
  for (const Case& c : {Case{{7, 13}, 11, true}, Case{{2, 7, 13}, 5, false},
                        Case{{3, 200, 19}, 33, true}, Case{{1, 1, 96}, 192, true}}) {
    INFO("x " << shape_string(c.x) << " out " << c.out);
    const std::int64_t in = c.x.back();
    const Tensor bias = random_tensor({c.out}, 61);
    const Linear layer =
        Linear::from(random_tensor({c.out, in}, 62), c.bias ? &bias : nullptr, "l");
    const Tensor x = random_tensor(c.x, 63);
    const Tensor ref = linear_reference(x, layer);
    Shape expected_shape = c.x;
    expected_shape.back() = c.out;
    CHECK(ref.shape() == expected_shape);
    CHECK(rel_error(linear(x, layer), ref) < 1e-5);
    Tensor ref_relu = ref;
    relu_inplace(ref_relu);
    CHECK(rel_error(linear(x, layer, true), ref_relu) < 1e-5);
  }
}

TEST_CASE("linear: errors", "[nn][linear]") {
  const Linear layer = Linear::from(Tensor({4, 3}), nullptr, "fc");
  REQUIRE_THROWS_WITH(linear(Tensor({2, 4}), layer),
                      Contains("linear: input [2, 4] must end in 3"));
  REQUIRE_THROWS_WITH(linear_reference(Tensor({2, 4}), layer), Contains("must end in 3"));
  REQUIRE_THROWS_WITH(Linear::from(Tensor({4, 3, 1}), nullptr, "head"),
                      Contains("head: linear weight must be [out, in], got [4, 3, 1]"));
  const Tensor bad_bias({3});
  REQUIRE_THROWS_WITH(Linear::from(Tensor({4, 3}), &bad_bias, "head"),
                      Contains("head.bias: expected shape [4], got [3]"));
}

TEST_CASE("layer_norm: biased variance, eps 1e-5, gamma and beta per channel", "[nn][linear]") {
  // Row 0: [1 2 3 4], mean 2.5, biased variance 1.25 (the unbiased one would be 5/3).
  // Row 1: [0 .002 .004 .006], mean .003, variance 5e-6: eps = 1e-5 dominates.
  Tensor x({2, 1, 4}, std::vector<float>{1, 2, 3, 4, 0, 0.002f, 0.004f, 0.006f});
  const Tensor gamma({4}, std::vector<float>{1, 2, 0.5f, -1});
  const Tensor beta({4}, std::vector<float>{0, 1, -1, 0.5f});
  layer_norm_inplace(x, gamma, beta);
  const double inv0 = 1.0 / std::sqrt(1.25 + 1e-5), inv1 = 1.0 / std::sqrt(5e-6 + 1e-5);
  const double expected[8] = {-1.5 * inv0 * 1 + 0,    -0.5 * inv0 * 2 + 1,    0.5 * inv0 * 0.5 - 1,
                              1.5 * inv0 * -1 + 0.5,  -0.003 * inv1 * 1 + 0,  -0.001 * inv1 * 2 + 1,
                              0.001 * inv1 * 0.5 - 1, 0.003 * inv1 * -1 + 0.5};
  CHECK(x.shape() == Shape{2, 1, 4});
  for (int i = 0; i < 8; ++i) {
    INFO(i);
    CHECK(x[i] == Approx(expected[i]).margin(1e-4));
  }
  // Without eps row 1 would be [-1.34, ...] * gamma: far from the above.
  CHECK(x[4] == Approx(-0.7746).margin(1e-3));

  Tensor custom({1, 2}, std::vector<float>{0, 2});
  layer_norm_inplace(custom, Tensor({2}, 1.0f), Tensor({2}), 1.0f);  // var 1, eps 1
  CHECK(custom[0] == Approx(-1 / std::sqrt(2.0)));
  CHECK(custom[1] == Approx(1 / std::sqrt(2.0)));

  Tensor bad({2, 3});
  REQUIRE_THROWS_WITH(layer_norm_inplace(bad, gamma, beta), Contains("layer_norm"));
  Tensor ok({2, 4});
  REQUIRE_THROWS_WITH(layer_norm_inplace(ok, gamma, Tensor({3})), Contains("layer_norm beta"));
}

TEST_CASE("embedding: a row of the table, index errors", "[nn][linear]") {
  const Tensor table({3, 4}, std::vector<float>{0, 1, 2, 3, 10, 11, 12, 13, 20, 21, 22, 23});
  const Tensor row = embedding(table, 1, "film.embed");
  CHECK(row.shape() == Shape{4});
  CHECK(row.values() == std::vector<float>{10, 11, 12, 13});
  CHECK(embedding(table, 2, "e").values() == std::vector<float>{20, 21, 22, 23});
  REQUIRE_THROWS_WITH(embedding(table, 3, "film.embed"),
                      Contains("film.embed: index 3 outside [0, 3)"));
  REQUIRE_THROWS_WITH(embedding(table, -1, "film.embed"), Contains("index -1 outside [0, 3)"));
  REQUIRE_THROWS_WITH(embedding(Tensor({12}), 0, "film.embed"),
                      Contains("film.embed: expected a rank-2 tensor"));
}

// ---------------------------------------------------------------------------------------------
// linear attention

namespace {

/// Independent of the engine: phi(x) = elu(x) + 1 written out, the quadratic sum per head.
Tensor naive_attention(const Tensor& q, const Tensor& k, const Tensor& v, int heads) {
  const std::int64_t n = q.dim(0), l = q.dim(1), s = k.dim(1), c = q.dim(2), d = c / heads;
  auto phi = [](double x) { return x > 0 ? x + 1.0 : std::exp(x); };
  Tensor out(q.shape());
  for (std::int64_t b = 0; b < n; ++b)
    for (std::int64_t h = 0; h < heads; ++h)
      for (std::int64_t i = 0; i < l; ++i) {
        std::vector<double> num(static_cast<std::size_t>(d), 0.0);
        double den = 0;
        for (std::int64_t j = 0; j < s; ++j) {
          double a = 0;
          for (std::int64_t e = 0; e < d; ++e)
            a += phi(q.at(b, i, h * d + e)) * phi(k.at(b, j, h * d + e));
          den += a;
          for (std::int64_t e = 0; e < d; ++e)
            num[static_cast<std::size_t>(e)] += a * v.at(b, j, h * d + e);
        }
        for (std::int64_t e = 0; e < d; ++e)
          out.at(b, i, h * d + e) = float(num[static_cast<std::size_t>(e)] / (den + 1e-6));
      }
  return out;
}

}  // namespace

TEST_CASE("linear_attention: hand case where the elu feature map matters", "[nn][attention]") {
  // q = 0 (phi = 1), keys -1 and 1 (phi = e^-1 and 2), values 2 and 4.
  const Tensor q({1, 1, 1}, std::vector<float>{0});
  const Tensor k({1, 2, 1}, std::vector<float>{-1, 1});
  const Tensor v({1, 2, 1}, std::vector<float>{2, 4});
  const double e = std::exp(-1.0);
  const double expected = (e * 2 + 2 * 4) / (e + 2 + 1e-6);  // 3.689; relu + 1 would give 3.333
  CHECK(linear_attention_reference(q, k, v, 1)[0] == Approx(expected).epsilon(1e-6));
  CHECK(linear_attention(q, k, v, 1)[0] == Approx(expected).epsilon(1e-6));

  // Two heads of one channel each: per head, phi(q) cancels and the output is the average of
  // v weighted by phi(k) of that head's channel only.
  const Tensor q2({1, 1, 2}, std::vector<float>{0.3f, -2});
  const Tensor k2({1, 2, 2}, std::vector<float>{-1, 1, 1, -1});
  const Tensor v2({1, 2, 2}, std::vector<float>{2, 10, 4, 20});
  const double head0 = (e * 2 + 2 * 4) / (e + 2), head1 = (2 * 10 + e * 20) / (2 + e);
  for (const Tensor& out :
       {linear_attention_reference(q2, k2, v2, 2), linear_attention(q2, k2, v2, 2)}) {
    CHECK(out[0] == Approx(head0).epsilon(1e-5));
    CHECK(out[1] == Approx(head1).epsilon(1e-5));
  }
  // One head over both channels mixes them: different numbers.
  CHECK(linear_attention(q2, k2, v2, 1)[0] != Approx(head0).epsilon(1e-3));
}

TEST_CASE("linear_attention: factorised equals the quadratic reference", "[nn][attention]") {
  std::uint64_t seed = 300;
  for (int heads : {1, 2, 4})
    for (bool cross : {false, true}) {
      INFO("heads " << heads << " cross " << cross);
      const std::int64_t n = 3, l = 11, s = 7, c = 16;
      // Inputs in [-3, 2]: about 60% negative, where elu(x) + 1 = exp(x) differs from x + 1.
      const Tensor source = random_tensor({n, s, c}, seed++, -3.0, 2.0);
      const Tensor v = random_tensor({n, s, c}, seed++, -2.0, 2.0);
      const Tensor q = cross ? random_tensor({n, l, c}, seed++, -3.0, 2.0) : source;
      const Tensor& k = source;
      const Tensor ref = linear_attention_reference(q, k, v, heads);
      const Tensor fast = linear_attention(q, k, v, heads);
      CHECK(ref.shape() == q.shape());
      CHECK(rel_error(fast, ref) < 1e-4);
      CHECK(rel_error(ref, naive_attention(q, k, v, heads)) < 1e-5);
      const Tensor one = with_threads(1, [&] { return linear_attention(q, k, v, heads); });
      CHECK(one.values() == fast.values());
    }
}

TEST_CASE("linear_attention: shape errors", "[nn][attention]") {
  const Tensor q({2, 5, 8}), k({2, 6, 8}), v({2, 6, 8});
  REQUIRE_NOTHROW(linear_attention(q, k, v, 4));
  REQUIRE_THROWS_WITH(linear_attention(q, k, v, 3), Contains("8 channels do not split into 3"));
  REQUIRE_THROWS_WITH(linear_attention(q, k, v, 0), Contains("do not split into 0 heads"));
  REQUIRE_THROWS_WITH(linear_attention(q, k, Tensor({2, 5, 8}), 2),
                      Contains("attention values: expected shape [2, 6, 8]"));
  REQUIRE_THROWS_WITH(linear_attention(Tensor({2, 5, 4}), k, v, 2), Contains("disagree"));
  REQUIRE_THROWS_WITH(linear_attention(Tensor({1, 5, 8}), k, v, 2), Contains("disagree"));
  REQUIRE_THROWS_WITH(linear_attention_reference(Tensor({5, 8}), k, v, 2),
                      Contains("attention queries: expected a rank-3"));
  REQUIRE_THROWS_WITH(linear_attention_reference(q, Tensor({6, 8}), v, 2),
                      Contains("attention keys"));
}

// ---------------------------------------------------------------------------------------------
// softmax

#if __has_include("gimm/nn/fast_exp.hpp")
TEST_CASE("fast_exp: relative error below 3e-7, clamped ends", "[nn][softmax]") {
  // Every float step of about 1e-4 over the whole non-clamped range [-87.3, 88].
  double worst = 0, worst_at = 0;
  for (float x = -87.3f; x <= 88.0f; x = std::nextafter(x, 100.0f) + 1e-4f) {
    const double exact = std::exp(double(x));
    const double rel = std::abs(double(fast_exp(x)) - exact) / exact;
    if (rel > worst) {
      worst = rel;
      worst_at = x;
    }
  }
  INFO("worst at " << worst_at);
  CHECK(worst < 3e-7);
  CHECK(fast_exp(0.0f) == 1.0f);
  CHECK(fast_exp(1.0f) == Approx(std::exp(1.0)).epsilon(3e-7));
  // Below -87.3 the result is 0 (no subnormals); above 88 it is exp(88) (no infinity).
  CHECK(fast_exp(-87.31f) == 0.0f);
  CHECK(fast_exp(-1000.0f) == 0.0f);
  CHECK(fast_exp(-INFINITY) == 0.0f);
  CHECK(std::isnormal(fast_exp(-87.3f)));
  CHECK(fast_exp(1000.0f) == fast_exp(88.0f));
  CHECK(std::isfinite(fast_exp(INFINITY)));
  CHECK(fast_exp(88.0f) == Approx(std::exp(88.0)).epsilon(3e-7));
}
#endif

TEST_CASE("softmax_rows_inplace: per row, stable for large values", "[nn][softmax]") {
  std::vector<float> x{0, std::log(2.0f), std::log(3.0f), 1000, 1000, 1000 + std::log(2.0f)};
  softmax_rows_inplace(x.data(), 2, 3);
  CHECK(x[0] == Approx(1.0 / 6));
  CHECK(x[1] == Approx(2.0 / 6));
  CHECK(x[2] == Approx(3.0 / 6));
  // 1000 + ln 2 rounds in float: use the offset actually stored.
  const double d = double(1000 + std::log(2.0f)) - 1000.0;
  CHECK(x[3] == Approx(1 / (2 + std::exp(d))));
  CHECK(x[4] == Approx(1 / (2 + std::exp(d))));
  CHECK(x[5] == Approx(std::exp(d) / (2 + std::exp(d))));
}

namespace {
/// softmax(sim, axis 0) * softmax(sim, axis 1), in double, from the definition.
Tensor naive_dual_softmax(const Tensor& sim) {
  const std::int64_t l = sim.dim(0), s = sim.dim(1);
  Tensor out(sim.shape());
  for (std::int64_t i = 0; i < l; ++i)
    for (std::int64_t j = 0; j < s; ++j) {
      double row = 0, col = 0, row_max = -1e300, col_max = -1e300;
      for (std::int64_t t = 0; t < s; ++t) row_max = std::max(row_max, double(sim.at(i, t)));
      for (std::int64_t t = 0; t < l; ++t) col_max = std::max(col_max, double(sim.at(t, j)));
      for (std::int64_t t = 0; t < s; ++t) row += std::exp(sim.at(i, t) - row_max);
      for (std::int64_t t = 0; t < l; ++t) col += std::exp(sim.at(t, j) - col_max);
      out.at(i, j) =
          float(std::exp(sim.at(i, j) - row_max) / row * std::exp(sim.at(i, j) - col_max) / col);
    }
  return out;
}
}  // namespace

TEST_CASE("dual_softmax: fast equals reference equals the definition", "[nn][softmax]") {
  for (const Shape& shape : {Shape{13, 17}, Shape{3, 5}, Shape{20, 4}, Shape{1, 6}}) {
    INFO(shape_string(shape));
    const Tensor sim = random_tensor(shape, 500 + shape[0], -8.0, 8.0);
    const Tensor ref = dual_softmax_reference(sim);
    Tensor fast = sim;
    dual_softmax_inplace(fast);
    CHECK(max_abs_diff(fast, ref) < 1e-6);
    CHECK(rel_error(fast, ref) < 1e-5);
    CHECK(rel_error(ref, naive_dual_softmax(sim)) < 1e-5);
  }
  SECTION("wide: several 256-column blocks, the last one partial") {
    const Tensor sim = random_tensor({37, 600}, 510, -6.0, 6.0);
    Tensor fast = sim;
    dual_softmax_inplace(fast);
    const Tensor ref = dual_softmax_reference(sim);
    CHECK(max_abs_diff(fast, ref) < 1e-6);
    CHECK(rel_error(fast, ref) < 1e-5);
    CHECK(rel_error(ref, naive_dual_softmax(sim)) < 1e-5);
    const Tensor one = with_threads(1, [&] {
      Tensor t = sim;
      dual_softmax_inplace(t);
      return t;
    });
    CHECK(one.values() == fast.values());
  }
  SECTION("temperature divides the similarities") {
    const Tensor sim = random_tensor({12, 300}, 520, -1.0, 1.0);
    for (float temperature : {0.1f, 1.0f, 4.0f}) {
      INFO("temperature " << temperature);
      Tensor scaled = sim;
      for (float& v : scaled.values()) v /= temperature;
      Tensor fast = sim;
      dual_softmax_inplace(fast, temperature);
      CHECK(rel_error(fast, dual_softmax_reference(scaled)) < 1e-5);
      CHECK(rel_error(fast, naive_dual_softmax(scaled)) < 1e-5);
    }
    // 0.1 is sharper than 1: the largest confidence grows.
    Tensor sharp = sim, plain = sim;
    dual_softmax_inplace(sharp, 0.1f);
    dual_softmax_inplace(plain, 1.0f);
    CHECK(*std::max_element(sharp.values().begin(), sharp.values().end()) >
          *std::max_element(plain.values().begin(), plain.values().end()));
    Tensor t = sim;
    REQUIRE_THROWS_WITH(dual_softmax_inplace(t, 0.0f), Contains("temperature must be > 0, got 0"));
    REQUIRE_THROWS_WITH(dual_softmax_inplace(t, -1.0f), Contains("got -1"));
  }
  SECTION("one row or one column reduces to a plain softmax along the other axis") {
    const Tensor row({1, 3}, std::vector<float>{0, std::log(2.0f), std::log(3.0f)});
    Tensor fast = row;
    dual_softmax_inplace(fast);  // the column softmax of a single row is 1
    for (const Tensor& t : {fast, dual_softmax_reference(row)}) {
      CHECK(t[0] == Approx(1.0 / 6));
      CHECK(t[1] == Approx(2.0 / 6));
      CHECK(t[2] == Approx(3.0 / 6));
    }
    const Tensor col = row.reshaped({3, 1});
    Tensor fast_col = col;
    dual_softmax_inplace(fast_col);
    for (std::int64_t i = 0; i < 3; ++i) CHECK(fast_col[i] == Approx(fast[i]));
  }
  SECTION("pieces: row softmax * column softmax on a non-symmetric matrix") {
    // sim = [[0, ln 2], [ln 3, 0]]: rows [1/3, 2/3], [3/4, 1/4]; columns [1/4, 3/4], [2/3, 1/3].
    const Tensor sim({2, 2}, std::vector<float>{0, std::log(2.0f), std::log(3.0f), 0});
    Tensor fast = sim;
    dual_softmax_inplace(fast);
    const std::vector<double> expected{1.0 / 3 * 1.0 / 4, 2.0 / 3 * 2.0 / 3, 3.0 / 4 * 3.0 / 4,
                                       1.0 / 4 * 1.0 / 3};
    const Tensor ref = dual_softmax_reference(sim);
    for (int i = 0; i < 4; ++i) {
      CHECK(fast[i] == Approx(expected[static_cast<std::size_t>(i)]));
      CHECK(ref[i] == Approx(expected[static_cast<std::size_t>(i)]));
    }
  }
  SECTION("large values stay finite") {
    Tensor sim = random_tensor({9, 11}, 600, -1000.0, 1000.0);
    sim.at(2, 3) = 1000.0f;
    sim.at(7, 1) = 1000.0f;
    Tensor fast = sim;
    dual_softmax_inplace(fast);
    const Tensor ref = dual_softmax_reference(sim);
    for (std::int64_t i = 0; i < fast.numel(); ++i) {
      REQUIRE(std::isfinite(fast[i]));
      REQUIRE(std::isfinite(ref[i]));
      CHECK(fast[i] >= 0.0f);
      CHECK(fast[i] <= 1.0f);
    }
    CHECK(max_abs_diff(fast, ref) < 1e-6);
    CHECK(fast.at(2, 3) == Approx(1.0f));
    CHECK(fast.at(7, 1) == Approx(1.0f));

    Tensor diag({2, 2}, std::vector<float>{1000, -1000, -1000, 1000});
    dual_softmax_inplace(diag);
    CHECK(diag.values() == std::vector<float>{1, 0, 0, 1});
  }
  REQUIRE_THROWS_WITH(dual_softmax_reference(Tensor({2, 3, 4})), Contains("dual_softmax"));
  Tensor bad({6});
  REQUIRE_THROWS_WITH(dual_softmax_inplace(bad), Contains("dual_softmax: expected a rank-2"));
}

TEST_CASE("soft_argmax: one-hot maps give the grid, x along columns", "[nn][softmax]") {
  const int window = 5;
  for (int r = 0; r < window; ++r)
    for (int c = 0; c < window; ++c) {
      std::vector<float> heat(25, 0.0f);
      heat[static_cast<std::size_t>(r * window + c)] = 1.0f;
      const Expectation e = soft_argmax(heat.data(), window);
      INFO("row " << r << " col " << c);
      CHECK(e.x == -1.0f + 0.5f * float(c));
      CHECK(e.y == -1.0f + 0.5f * float(r));
      CHECK(e.std == Approx(std::sqrt(1e-10f)));  // zero variance, clamped
    }
  // Explicitly: row 0, column 4 is the top-right corner (x = 1, y = -1).
  std::vector<float> heat(25, 0.0f);
  heat[4] = 1.0f;
  const Expectation corner = soft_argmax(heat.data(), window);
  CHECK(corner.x == 1.0f);
  CHECK(corner.y == -1.0f);
}

TEST_CASE("soft_argmax: spread", "[nn][softmax]") {
  const std::vector<float> uniform(25, 1.0f / 25);
  const Expectation e = soft_argmax(uniform.data(), 5);
  CHECK(e.x == Approx(0).margin(1e-6));
  CHECK(e.y == Approx(0).margin(1e-6));
  // var_x = var_y = mean of {1, .25, 0, .25, 1} = 0.5.
  CHECK(e.std == Approx(std::sqrt(2 * 0.5)).epsilon(1e-5));

  // Half on (row 0, col 0), half on (row 0, col 4): x = 0 with variance 1, y = -1 exactly.
  std::vector<float> two(25, 0.0f);
  two[0] = two[4] = 0.5f;
  const Expectation t = soft_argmax(two.data(), 5);
  CHECK(t.x == Approx(0).margin(1e-7));
  CHECK(t.y == -1.0f);
  CHECK(t.std == Approx(1.0));

  // Window 3: grid {-1, 0, 1}.
  const std::vector<float> w3{0, 0, 0, 0, 0, 0.25f, 0, 0, 0.75f};
  const Expectation e3 = soft_argmax(w3.data(), 3);
  CHECK(e3.x == Approx(1.0));
  CHECK(e3.y == Approx(0.75));
  CHECK(e3.std == Approx(std::sqrt(0.75 - 0.5625)));

  const float single = 1.0f;
  const Expectation e1 = soft_argmax(&single, 1);
  CHECK(e1.x == 0.0f);
  CHECK(e1.y == 0.0f);
  REQUIRE_THROWS_WITH(soft_argmax(&single, 0), Contains("window must be >= 1, got 0"));
}

// ---------------------------------------------------------------------------------------------
// resampling

TEST_CASE("upsample_bilinear: PyTorch interpolate(align_corners=True) 3x4 -> 6x8",
          "[nn][resample]") {
  const Tensor x({1, 1, 3, 4}, std::vector<float>{0.5f, -1.25f, 2.0f, 3.5f, 4.0f, 0.25f, -2.5f,
                                                  1.0f, -0.75f, 6.0f, 1.5f, -3.0f});
  // torch.nn.functional.interpolate(x, size=(6, 8), mode="bilinear", align_corners=True),
  // torch 1.13, float32.
  const std::vector<float> torch_out{
      0.5f,          -0.25000003f, -1.0f,        -0.32142857f, 1.0714287f,   2.2142856f,
      2.857143f,     3.5f,         1.9000001f,   0.8071428f,   -0.28571433f, -0.40714288f,
      -0.042857096f, 0.5285715f,   1.5142858f,   2.5000002f,   3.3f,         1.8642856f,
      0.4285714f,    -0.49285716f, -1.1571429f,  -1.1571428f,  0.17142864f,  1.5f,
      3.0499997f,    2.342857f,    1.6357143f,   0.51428586f,  -0.81428558f, -1.4285712f,
      -0.61428565f,  0.1999999f,   1.1499999f,   2.2428572f,   3.3357143f,   2.614286f,
      0.9857143f,    -0.28571427f, -0.84285724f, -1.4000001f,  -0.75f,       2.1428573f,
      5.0357146f,    4.714286f,    2.7857144f,   0.85714275f,  -1.0714288f,  -3.0000002f};
  const Tensor out = upsample_bilinear(x, 6, 8);
  REQUIRE(out.shape() == Shape{1, 1, 6, 8});
  for (std::size_t i = 0; i < torch_out.size(); ++i) {
    INFO("index " << i);
    CHECK(out.values()[i] == Approx(torch_out[i]).margin(2e-6));
  }
  // Corners map onto corners.
  CHECK(out.at(0, 0, 0, 0) == x.at(0, 0, 0, 0));
  CHECK(out.at(0, 0, 0, 7) == x.at(0, 0, 0, 3));
  CHECK(out.at(0, 0, 5, 0) == x.at(0, 0, 2, 0));
  CHECK(out.at(0, 0, 5, 7) == Approx(x.at(0, 0, 2, 3)).margin(1e-6));
}

TEST_CASE("upsample_bilinear: a linear ramp stays linear, planes are independent",
          "[nn][resample]") {
  // Plane (b, ch): f(y, x) = (b + 1) x - 2 y + 10 ch, sampled at y * (h-1)/(oh-1) etc.
  const std::int64_t h = 3, w = 4;
  Tensor x({2, 3, h, w});
  for (std::int64_t b = 0; b < 2; ++b)
    for (std::int64_t ch = 0; ch < 3; ++ch)
      for (std::int64_t y = 0; y < h; ++y)
        for (std::int64_t xx = 0; xx < w; ++xx)
          x.at(b, ch, y, xx) = float((b + 1) * xx - 2 * y + 10 * ch);
  for (const auto& size : {std::pair<std::int64_t, std::int64_t>{6, 8}, {5, 7}, {3, 4}, {9, 2}}) {
    const std::int64_t oh = size.first, ow = size.second;
    INFO(oh << "x" << ow);
    const Tensor out = upsample_bilinear(x, oh, ow);
    REQUIRE(out.shape() == Shape{2, 3, oh, ow});
    for (std::int64_t b = 0; b < 2; ++b)
      for (std::int64_t ch = 0; ch < 3; ++ch)
        for (std::int64_t y = 0; y < oh; ++y)
          for (std::int64_t xx = 0; xx < ow; ++xx) {
            const double sy = double(y) * double(h - 1) / double(oh - 1);
            const double sx = double(xx) * double(w - 1) / double(ow - 1);
            CHECK(out.at(b, ch, y, xx) ==
                  Approx(double(b + 1) * sx - 2 * sy + 10.0 * double(ch)).margin(1e-5));
          }
  }
  // Output size 1 samples the top-left pixel (PyTorch's align_corners=True).
  const Tensor one = upsample_bilinear(x, 1, 1);
  CHECK(one.shape() == Shape{2, 3, 1, 1});
  CHECK(one.at(1, 2, 0, 0) == x.at(1, 2, 0, 0));
  REQUIRE_THROWS_WITH(upsample_bilinear(x, 0, 4), Contains("bad output size 0x4"));
  REQUIRE_THROWS_WITH(upsample_bilinear(Tensor({3, 4, 5}), 6, 8),
                      Contains("upsample input: expected a rank-4"));
}

TEST_CASE("extract_windows: row-major pixels, zero padding, channel last", "[nn][resample]") {
  // map[ch, y, x] = 100 ch + 10 y + x + 1, so a zero can only be padding.
  const std::int64_t c = 2, h = 4, w = 5;
  std::vector<float> map(static_cast<std::size_t>(c * h * w));
  for (std::int64_t ch = 0; ch < c; ++ch)
    for (std::int64_t y = 0; y < h; ++y)
      for (std::int64_t x = 0; x < w; ++x)
        map[static_cast<std::size_t>((ch * h + y) * w + x)] = float(100 * ch + 10 * y + x + 1);
  auto value = [&](std::int64_t ch, std::int64_t y, std::int64_t x) {
    return (y < 0 || y >= h || x < 0 || x >= w) ? 0.0f : float(100 * ch + 10 * y + x + 1);
  };
  const std::vector<std::int64_t> rows{2, 0, 3}, cols{3, 0, 4};
  const Tensor out = extract_windows(map.data(), c, h, w, rows, cols, 3);
  REQUIRE(out.shape() == Shape{3, 9, 2});
  for (std::int64_t m = 0; m < 3; ++m)
    for (std::int64_t p = 0; p < 9; ++p)
      for (std::int64_t ch = 0; ch < c; ++ch) {
        INFO("centre " << m << " pixel " << p << " channel " << ch);
        CHECK(out.at(m, p, ch) == value(ch, rows[static_cast<std::size_t>(m)] - 1 + p / 3,
                                        cols[static_cast<std::size_t>(m)] - 1 + p % 3));
      }
  // Interior window around (row 2, col 3): pixel 1 is one row up (not one column left).
  CHECK(out.at(0, 4, 0) == 24.0f);   // centre
  CHECK(out.at(0, 1, 0) == 14.0f);   // (y 1, x 3)
  CHECK(out.at(0, 3, 0) == 23.0f);   // (y 2, x 2)
  CHECK(out.at(0, 8, 1) == 135.0f);  // (y 3, x 4), channel 1
  // Corner window around (0, 0): the first row and column are padding.
  CHECK(out.at(1, 0, 0) == 0.0f);
  CHECK(out.at(1, 2, 1) == 0.0f);
  CHECK(out.at(1, 6, 1) == 0.0f);
  CHECK(out.at(1, 4, 1) == 101.0f);
  CHECK(out.at(1, 8, 0) == 12.0f);
  // Bottom-right corner (3, 4): the last row and column are padding.
  CHECK(out.at(2, 0, 0) == 24.0f);
  CHECK(out.at(2, 4, 0) == 35.0f);
  CHECK(out.at(2, 5, 0) == 0.0f);
  CHECK(out.at(2, 7, 1) == 0.0f);

  const Tensor w5 = extract_windows(map.data(), c, h, w, {1}, {2}, 5);
  REQUIRE(w5.shape() == Shape{1, 25, 2});
  for (std::int64_t p = 0; p < 25; ++p)
    CHECK(w5.at(0, p, 1) == value(1, 1 - 2 + p / 5, 2 - 2 + p % 5));
  const Tensor none = extract_windows(map.data(), c, h, w, {}, {}, 5);
  CHECK(none.shape() == Shape{0, 25, 2});

  REQUIRE_THROWS_WITH(extract_windows(map.data(), c, h, w, {1, 2}, {1}, 3),
                      Contains("2 rows but 1 cols"));
  REQUIRE_THROWS_WITH(extract_windows(map.data(), c, h, w, {1}, {1}, 4),
                      Contains("window must be odd, got 4"));
}

// ---------------------------------------------------------------------------------------------
// positional encoding

TEST_CASE("sine_encoding: LoFTR's 2D sine encoding", "[nn][encoding]") {
  const std::int64_t channels = 16, h = 3, w = 5;
  const Tensor pe = sine_encoding(channels, h, w);
  REQUIRE(pe.shape() == Shape{channels, h, w});
  // Group 0 at (x = 1, y = 1), the top-left pixel: sin 1, cos 1, sin 1, cos 1.
  CHECK(pe.at(0, 0, 0) == Approx(std::sin(1.0)).margin(1e-6));
  CHECK(pe.at(1, 0, 0) == Approx(std::cos(1.0)).margin(1e-6));
  CHECK(pe.at(2, 0, 0) == Approx(std::sin(1.0)).margin(1e-6));
  CHECK(pe.at(3, 0, 0) == Approx(std::cos(1.0)).margin(1e-6));
  // x varies along the width (last axis), y along the height.
  CHECK(pe.at(0, 0, 2) == Approx(std::sin(3.0)).margin(1e-6));
  CHECK(pe.at(2, 0, 2) == Approx(std::sin(1.0)).margin(1e-6));
  CHECK(pe.at(0, 2, 0) == Approx(std::sin(1.0)).margin(1e-6));
  CHECK(pe.at(2, 2, 0) == Approx(std::sin(3.0)).margin(1e-6));
  CHECK(pe.at(3, 1, 4) == Approx(std::cos(2.0)).margin(1e-6));
  // Group g: div_g = exp(2 g (-ln 10000) / (C / 2)) = 10000^(-g / 4) for C = 16.
  for (std::int64_t g = 0; g < channels / 4; ++g) {
    const double div = std::exp(double(2 * g) * -std::log(10000.0) / double(channels / 2));
    CHECK(div == Approx(std::pow(10.0, -double(g))));
    for (std::int64_t y = 0; y < h; ++y)
      for (std::int64_t x = 0; x < w; ++x) {
        INFO("g " << g << " y " << y << " x " << x);
        CHECK(pe.at(4 * g, y, x) == Approx(std::sin(double(x + 1) * div)).margin(1e-6));
        CHECK(pe.at(4 * g + 1, y, x) == Approx(std::cos(double(x + 1) * div)).margin(1e-6));
        CHECK(pe.at(4 * g + 2, y, x) == Approx(std::sin(double(y + 1) * div)).margin(1e-6));
        CHECK(pe.at(4 * g + 3, y, x) == Approx(std::cos(double(y + 1) * div)).margin(1e-6));
      }
  }
  // C = 256 (the coarse width): group 1 uses div = 10000^(-2/128).
  const Tensor big = sine_encoding(256, 1, 2);
  const double div1 = std::pow(10000.0, -2.0 / 128.0);
  CHECK(big.at(4, 0, 1) == Approx(std::sin(2 * div1)).margin(1e-6));
  CHECK(big.at(7, 0, 1) == Approx(std::cos(div1)).margin(1e-6));
  REQUIRE_THROWS_WITH(sine_encoding(6, 2, 2), Contains("multiple of 4, got 6"));
  REQUIRE_THROWS_WITH(sine_encoding(0, 2, 2), Contains("got 0"));
}

TEST_CASE("nn ops: empty inputs are refused, not crashed on", "[nn]") {
  using gimm::nn::Tensor;
  Tensor x({2, 0});
  CHECK_THROWS_WITH(gimm::nn::layer_norm_inplace(x, Tensor({0}), Tensor({0})),
                    Catch::Contains("empty gamma"));
  CHECK_THROWS_WITH(gimm::nn::dual_softmax_reference(Tensor({3, 0})), Catch::Contains("3 x 0"));
  Tensor empty_sim({3, 0});
  CHECK_THROWS_WITH(gimm::nn::dual_softmax_inplace(empty_sim), Catch::Contains("[3, 0]"));
  CHECK_THROWS_WITH(gimm::nn::upsample_bilinear(Tensor({1, 1, 0, 4}), 2, 8),
                    Catch::Contains("[1, 1, 0, 4]"));
  const Tensor none;
  CHECK_THROWS_WITH(none.at(), Catch::Contains("empty tensor"));
}
