#pragma once
// gimm-match's two matchers, each in a file of its own beside examples/gimm_match.cpp (the command
// line, the dataset loop, DICOM): a change to the learned matcher's headers (the network, the
// gating) recompiles match_learned.cpp, one to the geometric matcher's match_geometric.cpp, and
// neither the other nor the command line (docs/performance.md, "Build time").
#include <chrono>
#include <memory>
#include <optional>
#include <string>

#include "gimm/core/image.hpp"
#include "gimm/geometry/camera.hpp"
#include "gimm/match/learned_options.hpp"
#include "gimm/match/matches.hpp"
#include "gimm/match/pair_matcher.hpp"

namespace gimm {
struct GeometricOptions;
}

namespace gimm_match {

/// One pair as the single-pair modes take it: from PNG + camera JSON files, or from DICOM.
struct LoadedPair {
  gimm::Image<float> a, b;
  std::optional<gimm::Camerad> camera_a, camera_b;
  /// The exposed fields (match/field_of_view.hpp); empty: the whole image.
  gimm::Image<std::uint8_t> field_a, field_b;
  const gimm::Image<std::uint8_t>* field(bool a_side) const {
    const auto& f = a_side ? field_a : field_b;
    return f.size() ? &f : nullptr;
  }
  /// The pair as the matchers take it (pointing into this).
  gimm::PairInput input(const std::string& id, int class_a = gimm::kUnknownViewClass,
                        int class_b = gimm::kUnknownViewClass) const {
    gimm::PairInput in;
    in.id = id;
    in.image_a = &a;
    in.image_b = &b;
    in.class_a = class_a;
    in.class_b = class_b;
    in.camera_a = camera_a;
    in.camera_b = camera_b;
    in.field_a = field(true);
    in.field_b = field(false);
    return in;
  }
};

/// Where one pair's results go; an empty path is not written.
struct PairOutputs {
  std::string pair, out, picture, tree, tree_vtk;
  std::chrono::steady_clock::time_point start;  ///< when gimm-match started, for its timings
};

/// A and B side by side with the matches drawn (picture.cpp).
void write_picture(const std::string& path, const gimm::Image<float>& a,
                   const gimm::Image<float>& b, const gimm::PairMatches& matches);

/// The learned matcher's weights and the flags given for it. What no flag sets comes from what
/// the weights record (input size, gate), else MatchOptions' defaults.
struct LearnedChoice {
  std::string weights;             ///< empty: the shipped weights
  std::optional<float> threshold;  ///< --threshold
  std::optional<int> input_size;   ///< --input-size
  gimm::GateChoice gate;           ///< --gate, --delta, --snap, as given
  std::string gate_name;           ///< --gate as given, for the summary line
  double max_reprojection = 0;     ///< --max-reprojection (0: the hard gate's delta)
};

/// The network behind the matcher interface (dataset mode); `options` completed as above.
std::unique_ptr<gimm::PairMatcher> learned_matcher(const LearnedChoice& choice,
                                                   gimm::MatchOptions& options);
/// One pair: matches, picture, triangulated tree; prints a summary line.
int match_learned_pair(const LearnedChoice& choice, gimm::MatchOptions options,
                       const LoadedPair& pair, int class_a, int class_b,
                       const PairOutputs& outputs);

std::unique_ptr<gimm::PairMatcher> geometric_matcher(const gimm::GeometricOptions& options);
/// One pair: matches, picture, tree (JSON and VTK); prints a summary line.
int match_geometric_pair(const LoadedPair& pair, const gimm::GeometricOptions& options,
                         const PairOutputs& outputs);

}  // namespace gimm_match
