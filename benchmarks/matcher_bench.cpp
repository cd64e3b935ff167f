// The GIMM matcher on the gimm engine, one pair per iteration (both backbones, coarse
// transformer, dual softmax, fine stage), at 256^2 and 512^2 inputs.
//   gimm_matcher_bench [--benchmark_filter=...]
// Environment (set by benchmarks/matcher/side_by_side.sh; all optional):
//   GIMM_MATCHER_WEIGHTS  weights (safetensors); default: random weights with the default config
//   GIMM_MATCHER_PAIRS    folder with pair_<S>.f32 (two S x S float32 images, row-major);
//                         default: a smooth random image and a shifted copy
//   GIMM_MATCHER_DUMP     folder: writes gimm_<S>.json (the matches of the last iteration)
// Counters: matches, peak_rss_mb (the process's peak resident set so far).
#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <cstdlib>
#include <fstream>
#include <random>
#include <string>

#include "gimm/io/files.hpp"
#include "gimm/nn/matcher_file.hpp"
#include "gimm/nn/tensor_pool.hpp"

namespace {

std::string env(const char* name) {
  const char* v = std::getenv(name);
  return v ? v : "";
}

gimm::nn::Matcher make_matcher() {
  const std::string path = env("GIMM_MATCHER_WEIGHTS");
  if (!path.empty()) return gimm::nn::load_matcher(path);
  std::mt19937 rng(0);
  gimm::nn::MatcherConfig config;
  config.threshold = 0.0f;
  return gimm::nn::Matcher(config, [&](const std::string& name, const gimm::nn::Shape& shape) {
    gimm::nn::Tensor t(shape);
    const bool variance = name.find("running_var") != std::string::npos;
    const bool norm_scale =
        name.find("norm") != std::string::npos && name.find("weight") != std::string::npos;
    const float fan_in = shape.size() > 1 ? float(t.numel() / shape[0]) : 1.0f;
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    for (float& v : t.values())
      v = variance || norm_scale ? 1.0f + 0.1f * u(rng) : u(rng) / std::sqrt(fan_in);
    return t;
  });
}

/// Two S x S images in [0, 1]: from GIMM_MATCHER_PAIRS, or a smooth pattern and a shifted copy.
std::pair<gimm::nn::Tensor, gimm::nn::Tensor> make_pair(std::int64_t size) {
  gimm::nn::Tensor a({1, 1, size, size}), b({1, 1, size, size});
  const std::string dir = env("GIMM_MATCHER_PAIRS");
  if (!dir.empty()) {
    const auto bytes = gimm::read_file_bytes(dir + "/pair_" + std::to_string(size) + ".f32");
    GIMM_CHECK(bytes.size() == std::size_t(2 * size * size * 4),
               "matcher_bench: pair_" << size << ".f32 has " << bytes.size() << " bytes");
    std::memcpy(a.data(), bytes.data(), std::size_t(size * size * 4));
    std::memcpy(b.data(), bytes.data() + size * size * 4, std::size_t(size * size * 4));
    return {a, b};
  }
  for (std::int64_t r = 0; r < size; ++r)
    for (std::int64_t c = 0; c < size; ++c) {
      auto f = [](double y, double x) {
        return 0.5 + 0.25 * std::sin(x / 7.0) * std::cos(y / 11.0);
      };
      a.at(0, 0, r, c) = float(f(double(r), double(c)));
      b.at(0, 0, r, c) = float(f(double(r) + 8, double(c) + 16));
    }
  return {a, b};
}

double peak_rss_mb() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return double(usage.ru_maxrss) / 1024.0;
}

void BM_MatchPair(benchmark::State& state) {
  const std::int64_t size = state.range(0);
  const gimm::nn::Matcher matcher = make_matcher();
  const auto [a, b] = make_pair(size);
  gimm::nn::MatcherOutput out;
  for (auto _ : state) {
    out = matcher.match(a, b, 1, 2);
    benchmark::DoNotOptimize(out.points1.data());
  }
  state.counters["matches"] = double(out.i_ids.size());
  state.counters["peak_rss_mb"] = peak_rss_mb();
  const std::string dump = env("GIMM_MATCHER_DUMP");
  if (!dump.empty()) {
    nlohmann::json j;
    for (std::size_t k = 0; k < out.i_ids.size(); ++k) {
      j["points0"].push_back({out.points0[k][0], out.points0[k][1]});
      j["points1"].push_back({out.points1[k][0], out.points1[k][1]});
      j["mconf"].push_back(out.coarse_confidence[k]);
    }
    gimm::write_json_file(dump + "/gimm_" + std::to_string(size) + ".json", j);
  }
}
BENCHMARK(BM_MatchPair)->Arg(256)->Arg(384)->Arg(512)->Unit(benchmark::kMillisecond)->UseRealTime();

/// The same pair with the engine keeping no activation between pairs (nn/tensor_pool.hpp at
/// limit 0): each pair allocates and first-touches every activation again, as before the pool.
void BM_MatchPairNoKeptTensors(benchmark::State& state) {
  gimm::nn::TensorPool& pool = gimm::nn::TensorPool::instance();
  pool.set_limit_bytes(0);
  BM_MatchPair(state);
  pool.set_limit_bytes(std::size_t{256} << 20);
}
BENCHMARK(BM_MatchPairNoKeptTensors)
    ->Arg(256)
    ->Arg(384)
    ->Arg(512)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
