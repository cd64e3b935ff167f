#pragma once
/// The two coronary trees: the right (RCA) and the left (LCA: left main, LAD, LCx). Anatomy
/// names them; the view protocol (labels/views.hpp) says which views are routine for each.
#include <string>

#include "gimm/core/error.hpp"

namespace gimm {

enum class CoronarySystem { RCA, LCA };

inline const char* to_string(CoronarySystem s) {
  return s == CoronarySystem::RCA ? "RCA" : "LCA";
}

inline CoronarySystem parse_coronary_system(const std::string& name) {
  if (name == "RCA") return CoronarySystem::RCA;
  if (name == "LCA") return CoronarySystem::LCA;
  GIMM_FAIL("coronary system must be RCA or LCA, got '" << name << "'");
}

}  // namespace gimm
