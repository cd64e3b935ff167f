#pragma once
// What the pipeline tests share: a scratch folder of their own under the build's test tree.
#include <filesystem>
#include <string>

namespace gimm_test {

/// GIMM_TEST_TMP/pipeline/<group>/<name>, emptied; created too when `create` (a job that
/// writes into a folder of its own making is given none).
inline std::filesystem::path fresh_pipeline_dir(const std::string& group, const std::string& name,
                                                bool create) {
  const std::filesystem::path dir =
      std::filesystem::path(GIMM_TEST_TMP) / "pipeline" / group / name;
  std::filesystem::remove_all(dir);
  if (create) std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace gimm_test
