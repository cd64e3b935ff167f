// gimm-match's learned matcher (match/learned.hpp): the network from its weights, over a dataset
// or one pair (examples/match/methods.hpp).
#include <iostream>
#include <nlohmann/json.hpp>

#include "gimm/io/files.hpp"
#include "gimm/match/learned.hpp"
#include "gimm/match/reconstruct.hpp"
#include "gimm/match/tree_file.hpp"
#include "gimm/nn/matcher_file.hpp"
#include "methods.hpp"

namespace gimm_match {

namespace {

/// The network of `choice`; completes `options` with what the weights record where no flag
/// said otherwise (input size, gate).
gimm::nn::Matcher load_network(const LearnedChoice& choice, gimm::MatchOptions& options) {
  gimm::nn::Matcher network = gimm::nn::load_matcher(choice.weights);
  if (choice.threshold) network.set_threshold(*choice.threshold);
  options.input_size = choice.input_size.value_or(network.config().input_size);
  gimm::apply_gate_choice(network.config(), choice.gate, options);
  return network;
}

/// The learned matcher's matches triangulated: JSON (gimm-tree/1) and VTK points.
void write_reconstruction(const std::string& json_path, const std::string& vtk_path,
                          const gimm::Reconstruction& rec) {
  if (!json_path.empty()) {
    gimm::TreeFile tree;
    for (const auto& p : rec.points) {
      gimm::TreePoint t;
      t.a = p.a;
      t.b = p.b;
      t.world = p.world;
      t.confidence = p.confidence;
      t.reprojection_px = Eigen::Vector2d(p.reprojection_a, p.reprojection_b);
      tree.points.push_back(t);
    }
    tree.dropped_degenerate = rec.dropped_degenerate;
    tree.dropped_reprojection = rec.dropped_reprojection;
    gimm::write_tree_file(json_path, tree);
  }
  if (!vtk_path.empty()) {
    std::vector<Eigen::Vector3d> points;
    for (const auto& p : rec.points) points.push_back(p.world);
    gimm::write_file_atomic(vtk_path,
                            gimm::vtk_polydata("gimm: triangulated matches, mm", points, {}));
  }
}

}  // namespace

std::unique_ptr<gimm::PairMatcher> learned_matcher(const LearnedChoice& choice,
                                                   gimm::MatchOptions& options) {
  gimm::nn::Matcher network = load_network(choice, options);
  return std::make_unique<gimm::LearnedMatcher>(std::move(network), options);
}

int match_learned_pair(const LearnedChoice& choice, gimm::MatchOptions options,
                       const LoadedPair& pair, int class_a, int class_b,
                       const PairOutputs& outputs) {
  const gimm::nn::Matcher matcher = load_network(choice, options);
  const gimm::Image<float>& a = pair.a;
  const gimm::Image<float>& b = pair.b;
  const auto loaded = std::chrono::steady_clock::now();
  const gimm::PairMatchResult result =
      gimm::match_pair(matcher, pair.input(outputs.pair, class_a, class_b), options);
  const auto matched = std::chrono::steady_clock::now();
  std::optional<gimm::Reconstruction> rec;
  if (!outputs.tree.empty() || !outputs.tree_vtk.empty())
    rec = gimm::reconstruct_matches(
        result.matches, *pair.camera_a, *pair.camera_b,
        choice.max_reprojection > 0 ? choice.max_reprojection : options.gate.delta_px);
  // All or nothing: a failure (a full disk) leaves the files of an earlier run as they were.
  gimm::write_all_or_nothing([&](const auto& at) {
    if (!outputs.picture.empty()) write_picture(at(outputs.picture).string(), a, b, result.matches);
    if (!outputs.out.empty()) gimm::write_matches(at(outputs.out), result.matches);
    if (rec) write_reconstruction(at(outputs.tree).string(), at(outputs.tree_vtk).string(), *rec);
  });
  const auto ms = [](auto d) { return std::chrono::duration<double, std::milli>(d).count(); };
  std::cout << "gimm-match: " << result.matches.size() << " matches (network " << result.candidates
            << ", in padding " << result.dropped_in_padding << ", gated out "
            << result.dropped_by_gate << ", outside the exposed field "
            << result.dropped_outside_field << "; F from " << result.fundamental_source()
            << ", gate " << choice.gate_name << "); load " << ms(loaded - outputs.start)
            << " ms, match " << ms(matched - loaded) << " ms\n";
  if (rec)
    std::cout << "gimm-match: " << rec->points.size() << " points triangulated ("
              << rec->dropped_reprojection << " dropped past the reprojection limit, "
              << rec->dropped_degenerate << " degenerate)\n";
  return 0;
}

}  // namespace gimm_match
