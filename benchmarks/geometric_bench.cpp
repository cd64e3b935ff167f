// The geometric matcher (match/geometric.hpp), one pair per iteration: centerlines, candidates,
// DP both ways, consistency. `masks`: from the dataset's vessel masks; `segmented`: from the
// images (vesselness and hysteresis included). Target (issue 15): <= 20 ms per 512^2 pair.
// `field`: finding one view's exposed field in its image (match/field_of_view.hpp), what the
// single-pair modes add per view when no shutter is given (on real frames, PNG input).
// `formed/...`: a dataset with formed views (gimm-dataset --formation, the clinical style):
// segmenting the formed images without their fields and inside them (the fill the field costs).
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
  gimm::Image<std::uint8_t> field_a, field_b;
  gimm::PairInput input;
};

bool load(LoadedPair& p, std::string& why, bool formed = false) {
  const char* dir = std::getenv("GIMM_GEOMETRIC_DATASET");
  if (!dir) {
    why = "set GIMM_GEOMETRIC_DATASET to a gimm-dataset folder";
    return false;
  }
  gimm::DatasetReader reader(dir);
  const std::string id = reader.pair_ids().front();
  const std::string patient = gimm::split_pair_id(id).first;
  p.truth = reader.pair(id);
  const gimm::DatasetLayout& layout = reader.layout();
  if (formed && !reader.has_formed_views()) {
    why = std::string(dir) + " has no formed views (gimm-dataset --formation)";
    return false;
  }
  const auto image = [&](const std::string& view) {
    return formed ? layout.view_formed(patient, view) : layout.view_image(patient, view);
  };
  p.a = gimm::read_png_unit(image(p.truth.view_a));
  p.b = gimm::read_png_unit(image(p.truth.view_b));
  if (formed) {
    p.field_a = gimm::read_png8(layout.view_field(patient, p.truth.view_a));
    p.field_b = gimm::read_png8(layout.view_field(patient, p.truth.view_b));
  }
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

/// What the matcher gets: the dataset's masks; its rendered images, segmented; its formed
/// images, segmented without their exposed fields or inside them.
enum class Input { masks, segmented, formed, formed_in_field };

void BM_Geometric(benchmark::State& state, Input input) {
  const bool formed = input == Input::formed || input == Input::formed_in_field;
  LoadedPair p;
  std::string why;
  if (!load(p, why, formed)) {
    state.SkipWithError(why.c_str());
    return;
  }
  if (input == Input::formed_in_field) {
    p.input.field_a = &p.field_a;
    p.input.field_b = &p.field_b;
  }
  gimm::GeometricOptions o;
  o.use_masks = input == Input::masks;
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
BENCHMARK_CAPTURE(BM_Geometric, masks, Input::masks)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_Geometric, segmented, Input::segmented)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_Geometric, formed, Input::formed)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_Geometric, formed_in_field, Input::formed_in_field)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

BENCHMARK_MAIN();
