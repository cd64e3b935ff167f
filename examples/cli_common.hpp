#pragma once
// Shared CLI plumbing for the example programs: C-arm flags, error reporting, main wrapper.
#include <CLI/CLI.hpp>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <iostream>
#include <new>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/geometry/carm.hpp"
#include "gimm/io/files.hpp"
#include "gimm/io/volume_file.hpp"
#include "gimm/nn/shipped_weights.hpp"
#include "gimm/version.hpp"

#if defined(__GLIBC__)
#include <malloc.h>  // mallopt
#endif

namespace gimm::cli {

/// A command line that parsed but asks for something that cannot be (flags that conflict, a
/// value a flag's owner refuses): a usage error like CLI11's own, exit 2. Its message names
/// the flag and the value.
class UsageError : public Error {
 public:
  using Error::Error;
};

/// Runs `read` (which turns flag values into the library's options) and reports what it
/// refuses as a usage error of `flags` (e.g. "--shard", "--rows/--cols/--pixel"), exit 2.
template <class Read>
auto flag_value(const std::string& flags, Read&& read) -> decltype(read()) {
  try {
    return read();
  } catch (const UsageError&) {
    throw;
  } catch (const Error& e) {
    std::string what = e.what();
    if (what.rfind("gimm: ", 0) == 0) what.erase(0, 6);
    throw UsageError("gimm: " + (flags.empty() ? what : flags + ": " + what));
  }
}

/// check_outputs_not_inputs (io/files.hpp) as a usage error: an output flag naming an input.
inline void refuse_outputs_over_inputs(const std::vector<NamedPath>& outputs,
                                       const std::vector<NamedPath>& inputs,
                                       bool folders_contain = false) {
  flag_value("", [&] { check_outputs_not_inputs(outputs, inputs, folders_contain); });
}

/// A volume input as the files it reads: the header and, for a detached NRRD/MetaImage
/// header, its data file, so that no output may replace either. A header that cannot be read is
/// left for the reader to report.
inline std::vector<NamedPath> volume_input(const std::string& flag, const std::string& path) {
  std::vector<NamedPath> files{{flag, path}};
  if (path.empty() || !std::filesystem::is_regular_file(path)) return files;
  try {
    const std::filesystem::path data = volume_data_file(path);
    if (data != std::filesystem::path(path)) files.push_back({flag + "'s data file", data});
  } catch (const Error&) {
  }
  return files;
}

/// Where the shipped weights are looked for, after $GIMM_WEIGHTS: the install tree
/// (<prefix>/share/gimm/weights beside <prefix>/bin), the source tree this binary was built from.
inline std::vector<std::filesystem::path> default_weights_dirs() {
  std::vector<std::filesystem::path> out;
  std::error_code ec;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) out.push_back(exe.parent_path().parent_path() / "share" / "gimm" / "weights");
#ifdef GIMM_SOURCE_WEIGHTS_DIR
  out.emplace_back(GIMM_SOURCE_WEIGHTS_DIR);
#endif
  return out;
}

inline std::string default_weights_hint() {
  return std::string("$GIMM_WEIGHTS, else share/gimm/weights/") + nn::kShippedWeights;
}

/// The shipped weights (nn/shipped_weights.hpp); an error naming every place looked in.
inline std::string default_weights() {
  return nn::find_shipped_weights(default_weights_dirs());
}

/// The value of `input` when it is a finite number, else nullopt (the range validators leave
/// those to CLI11's type check and to Finite).
inline std::optional<long double> finite_number(const std::string& input) {
  char* end = nullptr;
  const long double value = std::strtold(input.c_str(), &end);
  if (end == input.c_str() || *end != '\0') return std::nullopt;
  if (!std::isfinite(static_cast<double>(value))) return std::nullopt;
  return value;
}

/// Refuses a number below `min`, saying so in those words (CLI11's PositiveNumber prints the
/// double range, 4.9e-324 as 309 digits).
inline CLI::Validator at_least(double min) {
  return CLI::Validator(
      [min](std::string& input) -> std::string {
        const auto parsed = finite_number(input);
        if (!parsed) return {};  // CLI11 or Finite says what is wrong
        const long double value = *parsed;
        if (!(value >= min)) {
          std::ostringstream os;
          os << "must be >= " << min << ", got " << input;
          return os.str();
        }
        return {};
      },
      "", "AtLeast");
}

/// Refuses a number outside [min, max] (or [min, max) when !max_included), in those words.
inline CLI::Validator in_range(double min, double max, bool max_included) {
  return CLI::Validator(
      [=](std::string& input) -> std::string {
        const auto parsed = finite_number(input);
        if (!parsed) return {};  // CLI11 or Finite says what is wrong
        const long double value = *parsed;
        if (value >= min && (max_included ? value <= max : value < max)) return {};
        std::ostringstream os;
        os << "must be in [" << min << ", " << max << (max_included ? "]" : ")") << ", got "
           << input;
        return os.str();
      },
      "", "InRange");
}

/// Refuses an integer that is neither 0 (off, as is) nor in [min, max].
inline CLI::Validator zero_or_in(long long min, long long max) {
  return CLI::Validator(
      [=](std::string& input) -> std::string {
        char* end = nullptr;
        const long long value = std::strtoll(input.c_str(), &end, 10);
        if (end == input.c_str() || *end != '\0') return {};  // not an integer: CLI11 says so
        if (value == 0 || (value >= min && value <= max)) return {};
        return "must be 0 or in [" + std::to_string(min) + ", " + std::to_string(max) + "], got " +
               input;
      },
      "", "ZeroOrInRange");
}

/// Refuses a number that is not above zero ("must be > 0, got -5").
inline const CLI::Validator Positive(
    [](std::string& input) -> std::string {
      const auto value = finite_number(input);
      if (!value) return {};  // CLI11 or Finite says what is wrong
      if (!(*value > 0)) return "must be > 0, got " + input;
      return {};
    },
    "", "Positive");

/// A C-arm position (isocentre, table), mm, and a detector pitch, mm, within CArm's bounds.
inline const CLI::Validator position_mm =
    in_range(-CArm::kMaxPositionMm, CArm::kMaxPositionMm, true);
inline const CLI::Validator pitch_mm = in_range(CArm::kMinPixelMm, CArm::kMaxDistanceMm, true);

/// The C-arm flags shared by gimm-carm and gimm-drr; fills `carm`.
struct CArmFlags {
  std::string model = "perspective";
  std::vector<double> isocenter;
  std::vector<double> principal_point;
  std::vector<double> table;

  void add(CLI::App& app, CArm& carm, bool angles_required) {
    auto* primary = app.add_option("--primary", carm.primary_deg, "primary angle, deg (+LAO/-RAO)");
    auto* secondary = app.add_option("--secondary", carm.secondary_deg,
                                     "secondary angle, deg (+cranial/-caudal)");
    if (angles_required) {
      primary->required();
      secondary->required();
    }
    app.add_option("--sid", carm.sid_mm, "source-to-detector distance, mm")
        ->check(Positive)
        ->capture_default_str();
    app.add_option("--sod", carm.sod_mm, "source-to-isocentre distance, mm")
        ->check(Positive)
        ->capture_default_str();
    app.add_option("--rows", carm.rows, "detector rows")->check(at_least(1))->capture_default_str();
    app.add_option("--cols", carm.cols, "detector columns")
        ->check(at_least(1))
        ->capture_default_str();
    app.add_option("--pixel", carm.pixel_mm, "detector pixel pitch, mm")
        ->check(Positive)
        ->capture_default_str();
    app.add_option("--model", model, "perspective|orthographic")
        ->check(CLI::IsMember({"perspective", "orthographic"}))
        ->capture_default_str();
    app.add_option("--isocenter", isocenter, "isocentre X Y Z, world mm (LPS)")->expected(3);
    app.add_option("--principal-point", principal_point, "principal point U V, px")->expected(2);
    app.add_option("--table", table,
                   "table position LATERAL VERTICAL LONGITUDINAL, mm, relative to the table of "
                   "the isocentre (the patient rides on it: the isocentre moves to patient -x, "
                   "-y, -z; head-first supine)")
        ->expected(3);
  }

  /// Applies the parsed string/vector flags to `carm` and validates it.
  void finish(CArm& carm) const {
    carm.model =
        model == "perspective" ? ProjectionModel::perspective : ProjectionModel::orthographic;
    if (!isocenter.empty()) carm.isocenter = {isocenter[0], isocenter[1], isocenter[2]};
    if (!principal_point.empty())
      carm.principal_point = Eigen::Vector2d(principal_point[0], principal_point[1]);
    if (!table.empty()) carm.table_mm = {table[0], table[1], table[2]};
    flag_value(
        "the camera flags (--primary --secondary --sid --sod --rows --cols --pixel "
        "--isocenter --principal-point --table)",
        [&] { carm.validate(); });
  }
};

/// Refuses a FLOAT value that is not a finite double. CLI11 reads floats with strtold, which
/// takes "nan" and "inf", and a value beyond double's range ("1e999") becomes inf when narrowed;
/// CLI11's range checks all compare false with NaN and let it through. (gimm's float options are
/// all double.) No description: the help keeps reading "FLOAT".
inline const CLI::Validator Finite(
    [](std::string& input) -> std::string {
      char* end = nullptr;
      const long double value = std::strtold(input.c_str(), &end);
      if (end == input.c_str() || *end != '\0') return {};  // not a number: CLI11 says so
      if (!std::isfinite(static_cast<double>(value)))
        return "must be a finite number, got " + input;
      return {};
    },
    "", "Finite");

/// Refuses an integer CLI11 would wrap or saturate: strtoull reads "-1" as 2^64-1, and both
/// strtoull and strtoll clamp an out-of-range value to the type's limit without complaint.
inline CLI::Validator integer_in_range(bool is_unsigned) {
  return CLI::Validator(
      [is_unsigned](std::string& input) -> std::string {
        const char* s = input.c_str();
        while (*s == ' ' || *s == '\t') ++s;
        if (is_unsigned && *s == '-') return "must be a non-negative integer, got " + input;
        char* end = nullptr;
        errno = 0;
        if (is_unsigned)
          static_cast<void>(std::strtoull(s, &end, 0));
        else
          static_cast<void>(std::strtoll(s, &end, 0));
        if (end == s || *end != '\0') return {};  // not an integer: CLI11 says so
        if (errno == ERANGE) return "out of range, got " + input;
        return {};
      },
      "", is_unsigned ? "NonNegativeInteger" : "Integer");
}

/// Refuses an empty value for a number: CLI11 reads "" as 0, past the flag's own range check.
inline const CLI::Validator NotEmpty(
    [](std::string& input) -> std::string {
      if (input.find_first_not_of(" \t") == std::string::npos)
        return "must be a number, got an empty value";
      return {};
    },
    "", "NotEmpty");

/// Refuses an empty path: an output named "" was written as hidden files or not at all.
inline const CLI::Validator NotEmptyPath(
    [](std::string& input) -> std::string {
      if (input.empty()) return "must be a path, got an empty value";
      return {};
    },
    "", "NotEmptyPath");

/// The path flags that an empty value would turn into hidden files or nothing: the CLIs'
/// outputs (files, prefixes or folders), and --tree, an output of gimm-match and an input of
/// gimm-eval (an empty input path is refused the same way).
inline bool is_path_flag(const std::string& name) {
  for (const char* flag : {"--out", "--picture", "--tree", "--tree-vtk", "--timings"})
    if (name == flag) return true;
  return false;
}

/// CLI11's type name of `option` ("FLOAT", "UINT", "INT", ...), without its validators'.
inline std::string base_type_name(const CLI::Option& option) {
  const std::string full = option.get_type_name();
  return full.substr(0, full.find(':'));
}

/// The numeric contract of every gimm CLI, applied to every option of `app` and its subcommands
/// by type: FLOAT (double, and vectors of it) must be finite, UINT (any unsigned) must
/// not be negative, and no integer may overflow its type. One place, so an option added later
/// cannot miss it.
inline void check_numbers(CLI::App& app) {
  for (CLI::Option* option : app.get_options()) {
    const std::string type = base_type_name(*option);
    if (type == "FLOAT" || type == "UINT" || type == "INT") option->check(NotEmpty);
    if (is_path_flag(option->get_name())) option->check(NotEmptyPath);
    if (type == "FLOAT")
      option->check(Finite);
    else if (type == "UINT" || type == "INT")
      option->check(integer_in_range(type == "UINT"));
  }
  for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) check_numbers(*sub);
}

/// The program's name for messages: the App's name, else argv[0] without its folder.
inline std::string program_name(const CLI::App& app, int argc, char** argv) {
  if (!app.get_name().empty()) return app.get_name();
  return argc > 0 ? std::filesystem::path(argv[0]).filename().string() : std::string("gimm");
}

/// gimm-match's allocator policy: it allocates and frees the same large images for every pair.
/// glibc gives freed memory back to the system as soon as a few MB of it sit free at the top of
/// the heap, and getting it back costs a page fault per 4 KB page: on one machine (2026-12-05)
/// that was half of gimm-match's time with the geometric matcher segmenting. Freed memory up to
/// 256 MB stays mapped for the next pair instead (peak memory within 2 MB). Not for
/// gimm-dataset: there it cost 10% of the time and 40 MB of peak memory on a CT-size patient
/// (docs/performance.md, "Geometric matcher"). Other C libraries: their own policy.
inline void keep_freed_memory() {
#if defined(__GLIBC__)
  mallopt(M_MMAP_THRESHOLD, 32 << 20);  // images come from the heap, not one mapping each
  mallopt(M_TRIM_THRESHOLD, 256 << 20);
  mallopt(M_TOP_PAD, 64 << 20);
#endif
}

/// The library's messages name its options ("SplitOptions::allow_single"), a CLI's user knows
/// its flags: each CLI lists which flag sets which option (set once in main, before run), and
/// its messages show the flag beside the option.
inline std::vector<std::pair<std::string, std::string>>& option_flags() {
  static std::vector<std::pair<std::string, std::string>> table;
  return table;
}

/// `text` with each option of option_flags() followed by " (flag)" where it first appears.
inline std::string with_flags(std::string text) {
  for (const auto& [option, flag] : option_flags())
    if (const std::size_t at = text.find(option); at != std::string::npos)
      text.insert(at + option.size(), " (" + flag + ")");
  return text;
}

/// The command-line contract of every gimm CLI: parses `argv` into `app`, then runs `body`.
/// - --help prints the help, --version prints "<name> <version>"; both exit 0 (stdout).
/// - A usage error (unknown flag, missing or malformed value, failed check, non-finite float,
///   negative unsigned) prints one line "error: <what, naming the flag>" and exits 2.
/// - A UsageError thrown by `body` (flags that conflict, a value the library refuses) is one
///   too: exit 2.
/// - Other gimm and std errors thrown by `body` print "error: ..." and exit 1.
/// - Messages carry the flag beside each library option they name (option_flags()).
template <class Body>
int run(CLI::App& app, int argc, char** argv, Body&& body) {
  const std::string name = program_name(app, argc, argv);
  app.set_version_flag("--version", name + " " GIMM_VERSION_STRING);
  check_numbers(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    // CLI11 checks required options before unknown ones, though a mistyped required flag is the
    // unknown one: name that. (And CLI11 lists unknown arguments last first: list them in order.)
    const std::vector<std::string> extras = app.remaining(true);
    std::string what = e.what();
    if (!extras.empty() && (dynamic_cast<const CLI::ExtrasError*>(&e) ||
                            dynamic_cast<const CLI::RequiredError*>(&e))) {
      what = extras.size() > 1 ? "The following arguments were not expected:"
                               : "The following argument was not expected:";
      for (const auto& arg : extras) what += " " + arg;
    }
    for (char& c : what)
      if (c == '\n' || c == '\r') c = ' ';
    std::cerr << "error: " << printable(what) << " (see " << name << " --help)\n";
    return 2;
  }
  try {
    return body();
  } catch (const UsageError& e) {
    std::cerr << "error: " << with_flags(e.what()) << " (see " << name << " --help)\n";
    return 2;
  } catch (const std::bad_alloc&) {
    // Readers name their file (read_volume); elsewhere the command line is what can be named.
    std::cerr << "error: out of memory: " << name << " could not allocate what its inputs ask "
              << "for (a process memory limit, or an input larger than it says?); arguments:";
    for (int i = 1; i < argc; ++i) std::cerr << " " << printable(argv[i]);
    std::cerr << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "error: " << with_flags(printable(e.what())) << "\n";
    return 1;
  }
}

}  // namespace gimm::cli

/// GIMM_CHECK for a command line's own rules (flags that conflict or go together): a usage
/// error, exit 2; `msg` names the flags.
#define GIMM_USAGE_CHECK(cond, msg) GIMM_CHECK_AS(::gimm::cli::UsageError, cond, msg)
