// Where the shipped weights are found (nn/shipped_weights.hpp): $GIMM_WEIGHTS first, then the
// caller's places in order; nowhere is an IoError naming every place.
#include <catch2/catch.hpp>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "gimm/nn/shipped_weights.hpp"

namespace fs = std::filesystem;

TEST_CASE("Shipped weights: $GIMM_WEIGHTS, then the places in order, else every place named",
          "[nn]") {
  const fs::path root = fs::path(GIMM_TEST_TMP) / "shipped_weights";
  fs::remove_all(root);
  for (const char* dir : {"first", "second"}) fs::create_directories(root / dir);
  std::ofstream(root / "second" / gimm::nn::kShippedWeights) << "w";
  const std::vector<fs::path> dirs{root / "first", root / "second"};
  ::unsetenv("GIMM_WEIGHTS");
  CHECK(gimm::nn::find_shipped_weights(dirs) == (root / "second" / gimm::nn::kShippedWeights));
  std::ofstream(root / "first" / gimm::nn::kShippedWeights) << "w";
  CHECK(gimm::nn::find_shipped_weights(dirs) == (root / "first" / gimm::nn::kShippedWeights));
  std::ofstream(root / "mine.safetensors") << "w";
  ::setenv("GIMM_WEIGHTS", (root / "mine.safetensors").c_str(), 1);
  CHECK(gimm::nn::find_shipped_weights(dirs) == (root / "mine.safetensors"));
  // A $GIMM_WEIGHTS that does not exist falls through to the places (and is named if none).
  ::setenv("GIMM_WEIGHTS", (root / "missing.safetensors").c_str(), 1);
  CHECK(gimm::nn::find_shipped_weights(dirs) == (root / "first" / gimm::nn::kShippedWeights));
  const std::vector<fs::path> empty{root / "nothing_here"};
  CHECK_THROWS_AS(gimm::nn::find_shipped_weights(empty), gimm::IoError);
  CHECK_THROWS_WITH(gimm::nn::find_shipped_weights(empty), Catch::Contains("missing.safetensors") &&
                                                               Catch::Contains("nothing_here") &&
                                                               Catch::Contains("GIMM_WEIGHTS"));
  ::unsetenv("GIMM_WEIGHTS");
}
