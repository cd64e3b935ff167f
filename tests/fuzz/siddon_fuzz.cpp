// Fuzz target for the exact traversal (render/siddon.hpp): a random volume (sizes 1..40 per
// axis, values with empty blocks), a ray from the fragile families of boundary_rays.hpp or an
// arbitrary one, through index space or a scanner geometry; every exact path must lie within the
// range of right answers of the sorted-crossings oracle, and a volume of ones must give the
// chord. Built with AddressSanitizer, an out-of-grid read aborts.
//
// - With clang: -DGIMM_FUZZ_LIBFUZZER=ON builds gimm_siddon_libfuzzer (coverage-guided).
// - Everywhere: gimm_siddon_fuzz [iterations] [seed] feeds seeded random inputs to the same
//   function (test fuzz_siddon in CI, under ASan and UBSan).
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "../render/boundary_rays.hpp"
#include "gimm/render/drr.hpp"

namespace {

/// Choices taken from the fuzzer's bytes (zeros once they run out), with the interface of Rng
/// that boundary_rays.hpp draws from.
class ByteSource {
 public:
  ByteSource(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  std::uint64_t next(int bytes) {
    std::uint64_t x = 0;
    for (int b = 0; b < bytes; ++b) x = (x << 8) | (pos_ < size_ ? data_[pos_++] : 0);
    return x;
  }
  double uniform() { return static_cast<double>(next(4)) / 4294967296.0; }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  std::int64_t uniform_int(std::int64_t lo, std::int64_t hi) {
    return lo + static_cast<std::int64_t>(next(2) % static_cast<std::uint64_t>(hi - lo + 1));
  }

 private:
  const std::uint8_t* data_;
  std::size_t size_, pos_ = 0;
};

[[noreturn]] void fail(const char* what, const gimm::IndexRay& r, double got, double lo,
                       double hi) {
  std::fprintf(stderr,
               "siddon fuzz: %s: got %.17g, right answers [%.17g, %.17g]\n  origin %.17g %.17g "
               "%.17g\n  direction %.17g %.17g %.17g\n",
               what, got, lo, hi, r.origin.x, r.origin.y, r.origin.z, r.direction.x, r.direction.y,
               r.direction.z);
  std::abort();
}

void check_within(const char* what, const gimm::IndexRay& r, double got, double lo, double hi) {
  const double tolerance = 1e-9 * std::abs(hi) + 1e-12;
  if (!(got >= lo - tolerance && got <= hi + tolerance)) fail(what, r, got, lo, hi);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace gimm;
  ByteSource src(data, size);
  const bool large = src.uniform_int(0, 3) == 0;  // several empty-space blocks per axis
  const Eigen::Vector3i dims(static_cast<int>(src.uniform_int(1, large ? 40 : 9)),
                             static_cast<int>(src.uniform_int(1, large ? 40 : 9)),
                             static_cast<int>(src.uniform_int(1, large ? 40 : 9)));
  const int geometry = static_cast<int>(src.uniform_int(0, 3));  // 3: index space only
  const VolumeGeometry g = test::scanner_geometry(geometry, dims);
  // Values from a seeded generator (the bytes choose the seed and how empty the volume is):
  // zeros in whole boxes, so the skipping walk has occupied intervals to clip.
  Rng rng(src.next(4));
  const double empty_share = src.uniform();
  Volume<float> v(g, 0.0f);
  for (int k = 0; k < dims[2]; ++k)
    for (int j = 0; j < dims[1]; ++j)
      for (int i = 0; i < dims[0]; ++i) {
        const std::uint64_t box = (i / 5) * 73856093u ^ (j / 5) * 19349663u ^ (k / 5) * 83492791u;
        if (static_cast<double>((box ^ rng.next_u64() % 2) % 1000) / 1000.0 >= empty_share)
          v(i, j, k) = static_cast<float>(rng.uniform(0.1, 2.0));
      }
  IndexRay r;
  if (src.uniform_int(0, 4) == 0) {  // an arbitrary ray from outside or inside
    r.origin = glm::dvec3(src.uniform(-20, 60), src.uniform(-20, 60), src.uniform(-20, 60));
    r.direction = glm::dvec3(src.uniform(-1, 1), src.uniform(-1, 1), src.uniform(-1, 1));
    if (r.direction == glm::dvec3(0.0)) r.direction.x = 1;
  } else {
    r = test::fragile_ray(src, dims);
  }
  if (geometry < 3) r = test::through_world(g, r);

  const auto [lo, hi] = test::siddon_integral_bounds(v, r);
  check_within("siddon_integral", r, siddon_integral(v, r), lo, hi);
  double first = 0, second = 0, unused = 0;
  const IndexRay other{{-5, -4, -3}, {0.5, 0.6, 0.7}};
  siddon_integral_pair(v, r, other, first, unused);
  siddon_integral_pair(v, other, r, unused, second);
  check_within("siddon_integral_pair (first)", r, first, lo, hi);
  check_within("siddon_integral_pair (second)", r, second, lo, hi);
  const EmptyBlocks empty(v);
  check_within("siddon_integral_skipping", r, detail::siddon_integral_skipping(v, empty, r), lo,
               hi);
  const Volume<float> ones(g, 1.0f);
  const double chord = test::index_box_chord(r, dims);
  check_within("siddon_integral of ones (the chord)", r, siddon_integral(ones, r), chord, chord);
  return 0;
}

#ifndef GIMM_LIBFUZZER
int main(int argc, char** argv) {
  const long iterations = argc > 1 ? std::strtol(argv[1], nullptr, 10) : 100000;
  const std::uint64_t seed = argc > 2 ? std::strtoull(argv[2], nullptr, 10) : 1;
  if (iterations <= 0) {
    std::fprintf(stderr, "gimm_siddon_fuzz: iterations must be > 0, got '%s'\n", argv[1]);
    return 2;
  }
  gimm::Rng rng(seed);
  std::vector<std::uint8_t> input(96);
  for (long n = 0; n < iterations; ++n) {
    for (auto& byte : input) byte = static_cast<std::uint8_t>(rng.next_u64());
    LLVMFuzzerTestOneInput(input.data(), input.size());
  }
  std::printf("gimm_siddon_fuzz: %ld inputs (seed %llu), every path within the oracle\n",
              iterations, static_cast<unsigned long long>(seed));
  return 0;
}
#endif
