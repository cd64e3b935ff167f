// nn ops: the reference definitions against the fast paths the matcher runs.
// - conv2d: 3x3, 48 -> 48 channels, padding 1, one 64x64 image, ReLU (conv2d_reference's seven
//   loops vs banded im2col + GEMM).
// - linear_attention: L = S = 256 tokens, C = 96, 4 heads (the quadratic sum vs the factorised
//   phi(Q) (phi(K)^T V)).
// Counter gflops: useful multiply-adds x 2 per second of the definition's arithmetic (the same
// count for both, so the ratio is the speed-up). Correctness: tests/nn/ops_test.cpp.
#include <benchmark/benchmark.h>

#include <cstdint>

#include "gimm/core/rng.hpp"
#include "gimm/nn/attention.hpp"
#include "gimm/nn/conv2d.hpp"
#include "gimm/nn/tensor.hpp"

namespace {

using gimm::nn::Activation;
using gimm::nn::Conv2d;
using gimm::nn::Tensor;

Tensor random_tensor(gimm::nn::Shape shape, std::uint64_t seed) {
  Tensor t(std::move(shape));
  gimm::Rng rng(seed);
  for (float& v : t.values()) v = float(rng.uniform(-1.0, 1.0));
  return t;
}

constexpr std::int64_t kConvChannels = 48, kConvSize = 64;

struct ConvCase {
  Conv2d conv;
  Tensor x;
  ConvCase() {
    const Tensor bias = random_tensor({kConvChannels}, 2);
    conv = Conv2d::from(random_tensor({kConvChannels, kConvChannels, 3, 3}, 1), &bias, 1, 1,
                        "bench_conv");
    x = random_tensor({1, kConvChannels, kConvSize, kConvSize}, 3);
  }
};

const ConvCase& conv_case() {
  static const ConvCase c;
  return c;
}

void set_conv_flops(benchmark::State& state) {
  const double macs = double(kConvChannels * kConvChannels * 9 * kConvSize * kConvSize);
  state.counters["gflops"] =
      benchmark::Counter(2 * macs * double(state.iterations()) * 1e-9, benchmark::Counter::kIsRate);
}

void BM_Conv2dReference_3x3_48_64x64(benchmark::State& state) {
  const ConvCase& c = conv_case();
  for (auto _ : state) {
    Tensor y = gimm::nn::conv2d_reference(c.x, c.conv, Activation::relu);
    benchmark::DoNotOptimize(y.data());
  }
  set_conv_flops(state);
}
BENCHMARK(BM_Conv2dReference_3x3_48_64x64)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_Conv2dFast_3x3_48_64x64(benchmark::State& state) {
  const ConvCase& c = conv_case();
  for (auto _ : state) {
    Tensor y = gimm::nn::conv2d(c.x, c.conv, Activation::relu);
    benchmark::DoNotOptimize(y.data());
  }
  set_conv_flops(state);
}
BENCHMARK(BM_Conv2dFast_3x3_48_64x64)->Unit(benchmark::kMillisecond)->UseRealTime();

constexpr std::int64_t kTokens = 256, kWidth = 96;
constexpr int kHeads = 4;

struct AttentionCase {
  Tensor q = random_tensor({1, kTokens, kWidth}, 11);
  Tensor k = random_tensor({1, kTokens, kWidth}, 12);
  Tensor v = random_tensor({1, kTokens, kWidth}, 13);
};

const AttentionCase& attention_case() {
  static const AttentionCase c;
  return c;
}

void set_attention_flops(benchmark::State& state) {
  // The quadratic definition: per head, L x S dot products of D and L x S x D value updates.
  const double macs = double(kTokens) * double(kTokens) * double(kWidth) * 2.0;
  state.counters["gflops"] =
      benchmark::Counter(2 * macs * double(state.iterations()) * 1e-9, benchmark::Counter::kIsRate);
}

void BM_LinearAttentionReference_256x96_h4(benchmark::State& state) {
  const AttentionCase& c = attention_case();
  for (auto _ : state) {
    Tensor out = gimm::nn::linear_attention_reference(c.q, c.k, c.v, kHeads);
    benchmark::DoNotOptimize(out.data());
  }
  set_attention_flops(state);
}
BENCHMARK(BM_LinearAttentionReference_256x96_h4)->Unit(benchmark::kMicrosecond)->UseRealTime();

void BM_LinearAttentionFast_256x96_h4(benchmark::State& state) {
  const AttentionCase& c = attention_case();
  for (auto _ : state) {
    Tensor out = gimm::nn::linear_attention(c.q, c.k, c.v, kHeads);
    benchmark::DoNotOptimize(out.data());
  }
  set_attention_flops(state);
}
BENCHMARK(BM_LinearAttentionFast_256x96_h4)->Unit(benchmark::kMicrosecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
