// The geometric matcher (match/geometric.hpp), one pair per iteration: centerlines, candidates,
// DP both ways, consistency. `masks`: from the dataset's vessel masks; `segmented`: from the
// images (vesselness and hysteresis included). Target (issue 15): <= 20 ms per 512^2 pair.
// `field`: finding one view's exposed field in its image (match/field_of_view.hpp), what the
// single-pair modes add per view when no shutter is given (on real frames, PNG input).
//   GIMM_GEOMETRIC_DATASET=DIR gimm_geometric_bench   (DIR: a gimm-dataset; its first pair)
// Make a 512^2 dataset with benchmarks/matcher/geometric.sh. Without the variable the cases
// report an error and skip.
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <string>

#include "gimm/dataset/reader.hpp"
#include "gimm/io/png.hpp"
#include "gimm/match/field_of_view.hpp"
#include "gimm/match/geometric.hpp"

namespace {

struct LoadedPair {
  gimm::PairTruth truth;
  gimm::Image<float> a, b;
  gimm::PairInput input;
};

bool load(LoadedPair& p, std::string& why) {
  const char* dir = std::getenv("GIMM_GEOMETRIC_DATASET");
  if (!dir) {
    why = "set GIMM_GEOMETRIC_DATASET to a gimm-dataset folder";
    return false;
  }
  gimm::DatasetReader reader(dir);
  const std::string id = reader.pair_ids().front();
  const std::string patient = gimm::split_pair_id(id).first;
  p.truth = reader.pair(id);
  p.a = gimm::read_png_unit(reader.layout().view_image(patient, p.truth.view_a));
  p.b = gimm::read_png_unit(reader.layout().view_image(patient, p.truth.view_b));
  p.input.id = id;
  p.input.image_a = &p.a;
  p.input.image_b = &p.b;
  p.input.truth = &p.truth;
  p.input.mask_a = p.truth.mask_a.get();
  p.input.mask_b = p.truth.mask_b.get();
  p.input.camera_a = reader.camera(patient, p.truth.view_a);
  p.input.camera_b = reader.camera(patient, p.truth.view_b);
  return true;
}

void BM_Geometric(benchmark::State& state, bool masks) {
  LoadedPair p;
  std::string why;
  if (!load(p, why)) {
    state.SkipWithError(why.c_str());
    return;
  }
  gimm::GeometricOptions o;
  o.use_masks = masks;
  const gimm::GeometricMatcher matcher(o);
  std::size_t found = 0;
  for (auto _ : state) {
    const auto m = matcher.match(p.input);
    found = m.size();
    benchmark::DoNotOptimize(found);
  }
  state.counters["matches"] = double(found);
  state.counters["size"] = double(p.a.cols());
}

void BM_ExposedField(benchmark::State& state) {
  LoadedPair p;
  std::string why;
  if (!load(p, why)) {
    state.SkipWithError(why.c_str());
    return;
  }
  double fraction = 0;
  for (auto _ : state) {
    const gimm::Image<std::uint8_t> field = gimm::exposed_field(p.a);
    fraction = gimm::field_fraction(field);
    benchmark::DoNotOptimize(fraction);
  }
  state.counters["field"] = fraction;
  state.counters["size"] = double(p.a.cols());
}

}  // namespace

BENCHMARK(BM_ExposedField)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_Geometric, masks, true)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_Geometric, segmented, false)->Unit(benchmark::kMillisecond)->UseRealTime();

BENCHMARK_MAIN();
