#pragma once
/// Matching a pair of angiograms: images -> network input -> GIMM matcher -> points back in
/// image pixels -> epipolar gating -> PairMatches (the gimm-matches/1 predictions format).
///
/// Images become network input as match/network_input.hpp says (resized, vessel-enhanced when
/// the weights ask for it, padded to multiples of 8); matches with a point outside the image
/// content (in the padding, or refined past an edge) are dropped. Points come back as
/// u = (u_net + 0.5) W / W_net - 0.5 (pixel centres at integers; docs/evaluation.md).
///
/// Gating. With both cameras, F is the exact F of the two views (fundamental_from_cameras);
/// without, it is estimated from the matches as the reference does (gate_reference). Hard
/// gating removes the matches it rejects; soft and logit rescale confidences.
#include <Eigen/Core>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <string>

#include "gimm/core/error.hpp"
#include "gimm/core/image.hpp"
#include "gimm/geometry/camera.hpp"
#include "gimm/geometry/epipolar.hpp"
#include "gimm/geometry/gating.hpp"
#include "gimm/match/field_of_view.hpp"
#include "gimm/match/learned_options.hpp"
#include "gimm/match/matches.hpp"
#include "gimm/match/network_input.hpp"
#include "gimm/match/pair_matcher.hpp"
#include "gimm/nn/matcher.hpp"

namespace gimm {

inline void apply_gate_choice(const nn::MatcherConfig& weights, const GateChoice& chosen,
                              MatchOptions& options) {
  const bool recorded = !weights.gate_mode.empty();
  if (chosen.mode)
    options.gate.mode = *chosen.mode;
  else if (recorded)
    options.gate.mode = parse_gate_mode(weights.gate_mode);
  if (chosen.delta_px)
    options.gate.delta_px = *chosen.delta_px;
  else if (recorded && weights.gate_delta_px > 0)
    options.gate.delta_px = weights.gate_delta_px;
  if (chosen.snap)
    options.snap_to_epipolar = *chosen.snap;
  else if (recorded)  // snapping needs a gate's F; without a gate the record does not apply
    options.snap_to_epipolar = weights.gate_snap && options.gate.mode != GateMode::none;
}

/// The point of the line l = (l1, l2, l3) (l1 u + l2 v + l3 = 0) nearest to p.
inline Eigen::Vector2d foot_on_line(const Eigen::Vector3d& l, const Eigen::Vector2d& p) {
  const double n2 = l.x() * l.x() + l.y() * l.y();
  if (!(n2 > 0)) return p;
  return p - (l.x() * p.x() + l.y() * p.y() + l.z()) / n2 * Eigen::Vector2d(l.x(), l.y());
}

/// The network's matches gated (options.gate) with the pair's F: the cameras' when the pair
/// has them, else estimated from the matches (gate_reference); B points snapped onto their
/// epipolar lines when asked. The result carries the F used and its source.
inline PairMatches gate_matches(const PairMatches& raw, const PairInput& pair,
                                const MatchOptions& options, int& dropped_by_gate) {
  Points2<double> xa(2, raw.size()), xb(2, raw.size());
  VectorX<double> conf(static_cast<Eigen::Index>(raw.size()));
  for (std::size_t k = 0; k < raw.size(); ++k) {
    xa.col(k) = raw.points_a[k];
    xb.col(k) = raw.points_b[k];
    conf(k) = raw.confidence[k];
  }
  GateResult<double> gated;
  std::string source;
  if (options.gate.mode == GateMode::none || raw.size() == 0) {
    gated.confidence = conf;
    gated.keep.assign(raw.size(), 1);
  } else if (pair.camera_a) {
    source = "cameras";
    gated = gate_with_fundamental<double>(fundamental_from_cameras(*pair.camera_a, *pair.camera_b),
                                          xa, xb, conf, options.gate);
  } else {
    gated = gate_reference<double>(xa, xb, conf, options.gate);
    source = "matches";
  }
  PairMatches out;
  for (std::size_t k = 0; k < raw.size(); ++k) {
    if (!gated.keep[k]) {
      ++dropped_by_gate;
      continue;
    }
    const Eigen::Vector2d b =
        options.snap_to_epipolar && gated.F
            ? foot_on_line(*gated.F * raw.points_a[k].homogeneous(), raw.points_b[k])
            : raw.points_b[k];
    out.add(raw.points_a[k], b, gated.confidence(Eigen::Index(k)));
  }
  // The matches carry the F they were gated with (written with them, drawn by --picture).
  out.F = gated.F;
  out.F_source = gated.F ? source : "";
  return out;
}

/// The learned matcher on one pair: the network on both images, its matches back in image
/// pixels, gated with the pair's F (the cameras', else estimated from the matches), then those
/// with an end outside its exposed field dropped. Needs both images.
inline PairMatchResult match_pair(const nn::Matcher& matcher, const PairInput& pair,
                                  const MatchOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  options.gate.validate();
  GIMM_CHECK(!options.snap_to_epipolar || options.gate.mode != GateMode::none,
             "snapping to the epipolar line needs an F: a gate other than none");
  GIMM_CHECK(pair.image_a && pair.image_b, "learned: pair '" << pair.id << "' has no images");
  pair.validate();
  const Image<float>& image_a = *pair.image_a;
  const Image<float>& image_b = *pair.image_b;
  // Each image prepared once; both padded to the larger rows and columns (real angiograms of
  // two runs may differ in size).
  const NetworkImage kind = network_image_kind(matcher.config().input);
  NetworkInput a = prepare_network_input(image_a, options.input_size, kind, "image A");
  NetworkInput b = prepare_network_input(image_b, options.input_size, kind, "image B");
  const std::int64_t rows = std::max(a.padded_rows(), b.padded_rows());
  const std::int64_t cols = std::max(a.padded_cols(), b.padded_cols());
  pad_network_input(a, rows, cols);
  pad_network_input(b, rows, cols);
  const nn::MatcherOutput net = matcher.match(a.tensor, b.tensor, pair.class_a, pair.class_b);

  PairMatchResult result;
  result.candidates = static_cast<int>(net.i_ids.size());
  auto in_content = [](const std::array<float, 2>& p, const NetworkInput& in) {
    return p[0] >= -0.5f && p[1] >= -0.5f && p[0] <= in.content_cols - 1 + 0.5f &&
           p[1] <= in.content_rows - 1 + 0.5f;
  };
  auto to_image = [](const std::array<float, 2>& p, const NetworkInput& in) {
    return Eigen::Vector2d((p[0] + 0.5) * in.scale_u - 0.5, (p[1] + 0.5) * in.scale_v - 0.5);
  };
  PairMatches raw;
  for (std::size_t k = 0; k < net.i_ids.size(); ++k) {
    if (!in_content(net.points0[k], a) || !in_content(net.points1[k], b)) {
      ++result.dropped_in_padding;
      continue;
    }
    raw.add(to_image(net.points0[k], a), to_image(net.points1[k], b), net.coarse_confidence[k]);
  }
  result.matches = gate_matches(raw, pair, options, result.dropped_by_gate);
  result.matches.pair = pair.id;
  result.dropped_outside_field =
      static_cast<int>(drop_outside_fields(result.matches, pair.field_a, pair.field_b));
  result.seconds = detail::seconds_since(start);
  return result;
}

/// The learned matcher behind the matcher interface.
class LearnedMatcher : public PairMatcher {
 public:
  LearnedMatcher(nn::Matcher network, MatchOptions options)
      : network_(std::move(network)), options_(options) {}
  std::string name() const override { return "learned"; }

 protected:
  PairMatchResult run_method(const PairInput& pair) const override {
    return match_pair(network_, pair, options_);  // drops outside the fields itself
  }

 private:
  nn::Matcher network_;
  MatchOptions options_;
};

}  // namespace gimm
