#pragma once
/// The learned matcher's settings (MatchOptions, GateChoice) apart from the matcher
/// (learned.hpp): gimm-match's command line sets them without compiling the network or the
/// gating.
#include <optional>

#include "gimm/geometry/gate_options.hpp"

namespace gimm {

struct MatchOptions {
  int input_size = 0;  ///< 0: the image's own size; N: longer side resized to N (then padded)
  GateOptions gate{};  ///< mode (hard by default), tau, delta, reference F settings
  /// After gating, move each B point to the nearest point of its epipolar line F a: the match
  /// keeps its position along the line and loses its error across it (needs an F).
  bool snap_to_epipolar = false;
};

/// The gate settings a caller chose; each one left unset is what the weights record (their
/// "gate", tuned on validation pairs), else MatchOptions' default. gimm-match's flags and the
/// Python Matcher both resolve their defaults here.
struct GateChoice {
  std::optional<GateMode> mode;
  std::optional<double> delta_px;
  std::optional<bool> snap;
};

}  // namespace gimm
