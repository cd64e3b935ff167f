#pragma once
/// Where the matcher weights shipped with gimm (weights/README.md is their model card) are
/// found when the caller names none: $GIMM_WEIGHTS first, then the places the caller knows
/// (an install tree beside a binary, a Python package's folder, the source tree).
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "gimm/core/error.hpp"

namespace gimm::nn {

/// The shipped weights' file name.
inline constexpr const char* kShippedWeights = "gimm-phantom-128.safetensors";

/// $GIMM_WEIGHTS (if set), then `dir / kShippedWeights` for each of `dirs`, in order.
inline std::vector<std::filesystem::path> shipped_weights_candidates(
    const std::vector<std::filesystem::path>& dirs) {
  std::vector<std::filesystem::path> out;
  if (const char* env = std::getenv("GIMM_WEIGHTS")) out.emplace_back(env);
  for (const auto& dir : dirs) out.push_back(dir / kShippedWeights);
  return out;
}

/// The first existing candidate; else gimm::IoError naming every place looked in.
inline std::string find_shipped_weights(const std::vector<std::filesystem::path>& dirs) {
  std::string tried;
  for (const auto& p : shipped_weights_candidates(dirs)) {
    if (std::filesystem::is_regular_file(p)) return p.string();
    tried += " '" + p.string() + "'";
  }
  throw IoError("gimm: no weights given and the shipped weights are not at" + tried +
                " (set GIMM_WEIGHTS)");
}

}  // namespace gimm::nn
