// Coverage-guided fuzzing (libFuzzer, clang) of one reader of reader_targets.hpp, chosen at
// compile time by GIMM_FUZZ_TARGET (its name): one binary per reader, gimm_fuzz_<name>. Each
// input is written where the harnesses write it (input_path, in a folder of this process) and
// read back. gimm::Error is a clean refusal; any other exception aborts, so that libFuzzer keeps
// the input as a crash, as it does for what ASan and UBSan report.
//
// Build and run every target: tests/fuzz/run.sh --seconds S (docs/dev/fuzzing.md).
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <string>

#include "reader_targets.hpp"

namespace {

const gimm_fuzz::ReaderTarget& target() {
  static const gimm_fuzz::ReaderTarget chosen = [] {
    for (auto& t : gimm_fuzz::reader_targets(GIMM_FIXTURES_DIR))
      if (t.name == GIMM_FUZZ_TARGET) return t;
    std::fprintf(stderr, "reader_libfuzzer: no reader target '%s'\n", GIMM_FUZZ_TARGET);
    std::abort();
  }();
  return chosen;
}

const std::filesystem::path& input() {
  static const std::filesystem::path path = [] {
    const auto scratch = std::filesystem::temp_directory_path() /
                         ("gimm_fuzz_" + std::string(GIMM_FUZZ_TARGET) + "_" +
                          std::to_string(static_cast<long>(getpid())));
    const auto p = gimm_fuzz::input_path(scratch, target());
    std::filesystem::create_directories(p.parent_path());
    return p;
  }();
  return path;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  gimm::write_file_atomic(input(), data, size);
  try {
    target().read(input());
  } catch (const gimm::Error&) {
    // a clean refusal
  } catch (const std::exception& e) {
    std::fprintf(stderr, "reader_libfuzzer: %s: a non-gimm exception escaped: %s\n",
                 GIMM_FUZZ_TARGET, e.what());
    std::abort();
  }
  return 0;
}
