#pragma once
// Shared CLI plumbing for the example programs: C-arm flags, error reporting, main wrapper.
#include <CLI/CLI.hpp>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/geometry/carm.hpp"

namespace gimm::cli {

/// The shipped matcher weights' file name (weights/README.md is their model card).
inline constexpr const char* kShippedWeights = "gimm-phantom-128.safetensors";

/// Where the shipped weights are looked for, in order: $GIMM_WEIGHTS, the install tree
/// (<prefix>/share/gimm/weights beside <prefix>/bin), the source tree this binary was built from.
inline std::vector<std::filesystem::path> default_weights_candidates() {
  std::vector<std::filesystem::path> out;
  if (const char* env = std::getenv("GIMM_WEIGHTS")) out.emplace_back(env);
  std::error_code ec;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec)
    out.push_back(exe.parent_path().parent_path() / "share" / "gimm" / "weights" / kShippedWeights);
#ifdef GIMM_SOURCE_WEIGHTS_DIR
  out.push_back(std::filesystem::path(GIMM_SOURCE_WEIGHTS_DIR) / kShippedWeights);
#endif
  return out;
}

inline std::string default_weights_hint() {
  return std::string("$GIMM_WEIGHTS, else share/gimm/weights/") + kShippedWeights;
}

/// The first existing default_weights_candidates(); an error naming every place looked in.
inline std::string default_weights() {
  std::string tried;
  for (const auto& p : default_weights_candidates()) {
    if (std::filesystem::is_regular_file(p)) return p.string();
    tried += " '" + p.string() + "'";
  }
  GIMM_FAIL("no --weights given and the shipped weights are not at" << tried);
}

/// The C-arm flags shared by gimm-carm and gimm-drr; fills `carm`.
struct CArmFlags {
  std::string model = "perspective";
  std::vector<double> isocenter;
  std::vector<double> principal_point;

  void add(CLI::App& app, CArm& carm, bool angles_required) {
    auto* primary = app.add_option("--primary", carm.primary_deg, "primary angle, deg (+LAO/-RAO)");
    auto* secondary = app.add_option("--secondary", carm.secondary_deg,
                                     "secondary angle, deg (+cranial/-caudal)");
    if (angles_required) {
      primary->required();
      secondary->required();
    }
    app.add_option("--sid", carm.sid_mm, "source-to-detector distance, mm")->capture_default_str();
    app.add_option("--sod", carm.sod_mm, "source-to-isocentre distance, mm")->capture_default_str();
    app.add_option("--rows", carm.rows, "detector rows")->capture_default_str();
    app.add_option("--cols", carm.cols, "detector columns")->capture_default_str();
    app.add_option("--pixel", carm.pixel_mm, "detector pixel pitch, mm")->capture_default_str();
    app.add_option("--model", model, "perspective|orthographic")
        ->check(CLI::IsMember({"perspective", "orthographic"}))
        ->capture_default_str();
    app.add_option("--isocenter", isocenter, "isocentre X Y Z, world mm (LPS)")->expected(3);
    app.add_option("--principal-point", principal_point, "principal point U V, px")->expected(2);
  }

  /// Applies the parsed string/vector flags to `carm` and validates it.
  void finish(CArm& carm) const {
    carm.model =
        model == "perspective" ? ProjectionModel::perspective : ProjectionModel::orthographic;
    if (!isocenter.empty()) carm.isocenter = {isocenter[0], isocenter[1], isocenter[2]};
    if (!principal_point.empty())
      carm.principal_point = Eigen::Vector2d(principal_point[0], principal_point[1]);
    carm.validate();
  }
};

/// Runs `body`; CLI11 parse errors print usage and exit non-zero, gimm and std errors print
/// "error: ..." and exit 1.
template <class Body>
int run(CLI::App& app, int argc, char** argv, Body&& body) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    return body();
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace gimm::cli
