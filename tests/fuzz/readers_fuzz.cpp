// Mutation fuzzing of every reader that takes a file (the targets of reader_targets.hpp: NIfTI
// from a file and from memory, NRRD, MetaImage, PNG 8/16 bit, NPY, safetensors and matcher
// weights, camera, predictions, centerline and dataset JSON, DICOM when built with it). Each
// iteration mutates the target's seed (bit flips, extreme integers over a header word,
// truncation, appended or repeated bytes) and reads it back.
//
// A reader may refuse a file with gimm::Error (or a subclass). Anything else is a defect: another
// exception type escaping (reported here, exit 1), or a crash, leak or undefined behaviour
// (reported by AddressSanitizer / UBSan, which this target is built with). The coverage-guided
// counterpart is reader_libfuzzer.cpp (tests/fuzz/run.sh).
//
//   gimm_readers_fuzz [iterations per seed] [seed]      (ctest fuzz_readers: 400 1)
//   gimm_readers_fuzz --write-corpus DIR                (DIR/<target>/seed<suffix>: the seeds)
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "gimm/core/hash.hpp"
#include "gimm/core/rng.hpp"
#include "reader_targets.hpp"

namespace fs = std::filesystem;

namespace {

/// One random mutation of `b` (never empty in, possibly empty out).
std::vector<unsigned char> mutate(std::vector<unsigned char> b, gimm::Rng& rng) {
  const int rounds = 1 + static_cast<int>(rng.below(3));
  for (int k = 0; k < rounds && !b.empty(); ++k) {
    const std::size_t at = rng.below(b.size());
    switch (rng.below(6)) {
      case 0:  // bit flips
        for (int f = 0; f < 1 + int(rng.below(4)); ++f)
          b[rng.below(b.size())] ^= std::uint8_t(1u << rng.below(8));
        break;
      case 1: {  // an extreme integer over a (header) word
        static const std::uint64_t words[] = {0,          1,          0x7f,       0x80,
                                              0xff,       0x7fffffff, 0x80000000, 0xffffffff,
                                              1ull << 62, ~0ull,      65536,      4294967297ull};
        const std::uint64_t w = words[rng.below(sizeof(words) / sizeof(words[0]))];
        const std::size_t width = rng.below(2) ? 4 : 8;
        for (std::size_t i = 0; i < width && at + i < b.size(); ++i)
          b[at + i] = std::uint8_t(w >> (8 * i));
        break;
      }
      case 2:  // truncation
        b.resize(at);
        break;
      case 3:  // random bytes appended
        for (int i = 0; i < 1 + int(rng.below(64)); ++i) b.push_back(std::uint8_t(rng.below(256)));
        break;
      case 4: {  // a chunk repeated
        const std::size_t len = std::min<std::size_t>(b.size() - at, 1 + rng.below(32));
        b.insert(b.begin() + long(at), b.begin() + long(at), b.begin() + long(at + len));
        break;
      }
      default:  // a digit or a JSON/text delimiter changed
        b[at] = std::uint8_t("0123456789-.e+{}[]\":, \n"[rng.below(23)]);
    }
  }
  return b;
}

int write_corpus(const fs::path& dir) {
  const fs::path scratch = fs::path(GIMM_TEST_TMP) / "fuzz_corpus";
  for (const auto& t : gimm_fuzz::reader_targets(fs::path(GIMM_SOURCE_DIR) / "tests" / "data")) {
    const fs::path p = gimm_fuzz::input_path(scratch, t);
    fs::create_directories(p.parent_path());
    t.write_seed(p);
    t.read(p);  // a seed that does not read is a broken harness
    fs::create_directories(dir / t.name);
    const fs::path seed = dir / t.name / ("seed" + t.suffix);
    fs::copy_file(p, seed, fs::copy_options::overwrite_existing);
    std::printf("%s\n", seed.c_str());
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc == 3 && std::strcmp(argv[1], "--write-corpus") == 0) return write_corpus(argv[2]);
  const int iterations = argc > 1 ? std::atoi(argv[1]) : 400;
  const std::uint64_t seed = argc > 2 ? std::strtoull(argv[2], nullptr, 10) : 1;
  const fs::path scratch = fs::path(GIMM_TEST_TMP), dir = scratch / "fuzz_readers";
  fs::remove_all(dir);
  fs::create_directories(dir);
  int defects = 0;
  const auto targets = gimm_fuzz::reader_targets(fs::path(GIMM_SOURCE_DIR) / "tests" / "data");
#ifdef GIMM_LIBFUZZER_TARGETS
  // The libFuzzer links are a list in tests/CMakeLists.txt: it must name every reader here.
  std::string names;
  for (const auto& t : targets) names += (names.empty() ? "" : " ") + t.name;
  if (names != GIMM_LIBFUZZER_TARGETS) {
    std::fprintf(stderr,
                 "readers_fuzz: GIMM_READER_FUZZ_TARGETS in tests/CMakeLists.txt is '%s'; the "
                 "readers of reader_targets.hpp are '%s'\n",
                 GIMM_LIBFUZZER_TARGETS, names.c_str());
    ++defects;
  }
#endif
  for (const auto& t : targets) {
    gimm::Rng rng = gimm::Rng(seed).fork(gimm::stable_hash(t.name));
    int refused = 0;
    // The seed itself must read (a throw here ends the run: the harness is broken).
    const fs::path p = gimm_fuzz::input_path(scratch, t);
    t.write_seed(p);
    const std::vector<unsigned char> valid = gimm::read_file_bytes(p);
    t.read(p);
    for (int i = 0; i < iterations; ++i) {
      const std::vector<unsigned char> input = mutate(valid, rng);
      gimm::write_file_atomic(p, input.data(), input.size());
      try {
        t.read(p);
      } catch (const gimm::Error&) {
        ++refused;
      } catch (const std::exception& e) {
        ++defects;
        const fs::path keep = dir / ("defect_" + t.name + "_" + std::to_string(i) + t.suffix);
        fs::copy_file(p, keep, fs::copy_options::overwrite_existing);
        std::fprintf(stderr,
                     "%s: iteration %d: a non-gimm exception escaped: %s (input kept: %s)\n",
                     t.name.c_str(), i, e.what(), keep.c_str());
      }
    }
    std::printf("%-12s %d inputs, %d refused with gimm::Error, the rest read\n", t.name.c_str(),
                iterations, refused);
  }
  std::printf("readers_fuzz: %d defects\n", defects);
  return defects == 0 ? 0 : 1;
}
