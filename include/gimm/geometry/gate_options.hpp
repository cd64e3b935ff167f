#pragma once
/// The epipolar gate's settings (GateMode, GateOptions) apart from the gating itself
/// (gating.hpp): the matcher's options and the command lines that set them need only these, so
/// a change to the gating code does not recompile them.
#include <cmath>
#include <string>

#include "gimm/core/error.hpp"

namespace gimm {

enum class GateMode { none, hard, soft, logit };

inline const char* to_string(GateMode mode) {
  switch (mode) {
    case GateMode::none:
      return "none";
    case GateMode::hard:
      return "hard";
    case GateMode::soft:
      return "soft";
    case GateMode::logit:
      return "logit";
  }
  return "?";
}

inline GateMode parse_gate_mode(const std::string& name) {
  if (name == "none") return GateMode::none;
  if (name == "hard") return GateMode::hard;
  if (name == "soft") return GateMode::soft;
  if (name == "logit") return GateMode::logit;
  GIMM_FAIL("gate mode must be one of none|hard|soft|logit, got '" << name << "'");
}

struct GateOptions {
  GateMode mode = GateMode::hard;
  double tau = 2.0;       ///< temperature of soft and logit gates, px
  double delta_px = 2.0;  ///< hard-gate threshold on the (unsquared) symmetric distance, px
  // Reference F estimation (gate_reference only):
  int top_k = 256;       ///< most confident matches used to estimate F
  int min_matches = 32;  ///< fewer matches: no gating

  void validate() const {
    GIMM_CHECK(std::isfinite(tau) && tau > 0, "GateOptions: tau must be > 0, got " << tau);
    GIMM_CHECK(std::isfinite(delta_px) && delta_px >= 0,
               "GateOptions: delta_px must be >= 0, got " << delta_px);
    GIMM_CHECK(top_k >= 8, "GateOptions: top_k must be >= 8, got " << top_k);
    GIMM_CHECK(min_matches >= 8, "GateOptions: min_matches must be >= 8, got " << min_matches);
  }
};

}  // namespace gimm
