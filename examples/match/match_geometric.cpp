// gimm-match's geometric matcher (match/geometric.hpp): over a dataset, or one pair with its
// triangulated tree (examples/match/methods.hpp).
#include <iostream>
#include <nlohmann/json.hpp>

#include "gimm/io/files.hpp"
#include "gimm/match/geometric.hpp"
#include "gimm/match/reconstruct.hpp"
#include "gimm/match/tree_file.hpp"
#include "methods.hpp"

namespace gimm_match {

namespace {

/// The matches with their triangulated points: JSON (gimm-tree/1) and VTK polydata, lines
/// joining consecutive samples of one A branch.
void write_tree(const std::string& json_path, const std::string& vtk_path,
                const std::vector<gimm::GeometricMatch>& matches) {
  if (!json_path.empty()) {
    gimm::TreeFile tree;
    for (const auto& m : matches) {
      gimm::TreePoint t;
      t.a = m.a;
      t.b = m.b;
      t.world = m.world;
      t.confidence = m.confidence;
      t.branch = m.branch;
      t.consistent = m.consistent;
      tree.points.push_back(t);
    }
    gimm::write_tree_file(json_path, tree);
  }
  if (!vtk_path.empty()) {
    std::vector<Eigen::Vector3d> points;
    std::vector<std::pair<std::size_t, std::size_t>> lines;
    for (std::size_t k = 0; k < matches.size(); ++k) {
      points.push_back(matches[k].world);
      if (k > 0 && matches[k].branch == matches[k - 1].branch &&
          matches[k].sample == matches[k - 1].sample + 1)
        lines.emplace_back(k - 1, k);
    }
    gimm::write_file_atomic(
        vtk_path, gimm::vtk_polydata("gimm geometric matcher: triangulated centerline points, mm",
                                     points, lines));
  }
}

}  // namespace

std::unique_ptr<gimm::PairMatcher> geometric_matcher(const gimm::GeometricOptions& options) {
  return std::make_unique<gimm::GeometricMatcher>(options);
}

int match_geometric_pair(const LoadedPair& pair, const gimm::GeometricOptions& options,
                         const PairOutputs& outputs) {
  GIMM_ASSERT(pair.camera_a && pair.camera_b);  // gimm-match refuses the pair without them
  const gimm::Image<float>& a = pair.a;
  const gimm::Image<float>& b = pair.b;
  const gimm::PairInput input = pair.input(outputs.pair);
  const auto loaded = std::chrono::steady_clock::now();
  const gimm::GeometricPairResult result = gimm::GeometricMatcher(options).run_with_points(input);
  const auto matched = std::chrono::steady_clock::now();
  const std::vector<gimm::GeometricMatch>& found = result.points;
  const gimm::PairMatches& matches = result.matches;
  // All or nothing: a failure (a full disk) leaves the files of an earlier run as they were.
  gimm::write_all_or_nothing([&](const auto& at) {
    if (!outputs.picture.empty()) write_picture(at(outputs.picture).string(), a, b, matches);
    if (!outputs.out.empty()) gimm::write_matches(at(outputs.out), matches);
    write_tree(at(outputs.tree).string(), at(outputs.tree_vtk).string(), found);
  });
  std::size_t consistent = 0;
  for (const auto& m : found) consistent += m.consistent;
  const auto ms = [](auto d) { return std::chrono::duration<double, std::milli>(d).count(); };
  std::cout << "gimm-match: " << found.size() << " matches (geometric, " << consistent
            << " consistent both ways); load " << ms(loaded - outputs.start) << " ms, match "
            << ms(matched - loaded) << " ms\n";
  return 0;
}

}  // namespace gimm_match
