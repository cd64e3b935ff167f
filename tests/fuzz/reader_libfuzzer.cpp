// Coverage-guided fuzzing (libFuzzer, clang) of one reader of reader_targets.hpp, chosen by the
// name the binary is called by: gimm_fuzz_<name> is a link to the one binary gimm_fuzz_readers
// (one compile instead of one per reader: 16 x 40 s of clang on two cores). Each
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

gimm_fuzz::ReaderTarget chosen;  // set once by LLVMFuzzerInitialize

const gimm_fuzz::ReaderTarget& target() {
  return chosen;
}

const std::filesystem::path& input() {
  static const std::filesystem::path path = [] {
    const auto scratch =
        std::filesystem::temp_directory_path() /
        ("gimm_fuzz_" + target().name + "_" + std::to_string(static_cast<long>(getpid())));
    const auto p = gimm_fuzz::input_path(scratch, target());
    std::filesystem::create_directories(p.parent_path());
    return p;
  }();
  return path;
}

}  // namespace

// The reader is the binary's name after "gimm_fuzz_" (argv[0], before libFuzzer's own flags).
extern "C" int LLVMFuzzerInitialize(int* argc, char*** argv) {
  const std::string prefix = "gimm_fuzz_";
  const std::string called = *argc > 0 ? std::filesystem::path((*argv)[0]).filename().string() : "";
  const std::string name = called.rfind(prefix, 0) == 0 ? called.substr(prefix.size()) : called;
  std::string names;
  for (auto& t : gimm_fuzz::reader_targets(GIMM_FIXTURES_DIR)) {
    if (t.name == name) {
      chosen = t;
      return 0;
    }
    names += " " + t.name;
  }
  std::fprintf(stderr,
               "reader_libfuzzer: called as '%s': no reader target '%s'; call it through one of "
               "the links gimm_fuzz_<target>, target one of:%s\n",
               called.c_str(), name.c_str(), names.c_str());
  std::exit(2);
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  gimm::write_file_atomic(input(), data, size);
  try {
    target().read(input());
  } catch (const gimm::Error&) {
    // a clean refusal
  } catch (const std::exception& e) {
    std::fprintf(stderr, "reader_libfuzzer: %s: a non-gimm exception escaped: %s\n",
                 target().name.c_str(), e.what());
    std::abort();
  }
  return 0;
}
