#pragma once
/// The clinical view protocol of the released dataset (reference-notes.md): 11 view classes,
/// their C-arm angle ranges, and the coronary system each belongs to.
///
/// Class ids are 1..11 in table order; 0 means unknown (the matcher's 12th embedding row).
/// Angles in degrees: primary +LAO / -RAO, secondary +cranial / -caudal. When sampling, each
/// range is widened by kViewJitterDeg on both sides and drawn uniformly.
#include <array>
#include <string>
#include <vector>

#include "gimm/anatomy/coronary_system.hpp"
#include "gimm/core/error.hpp"

namespace gimm {

struct AngleRange {
  double lo;
  double hi;
  double centre() const { return 0.5 * (lo + hi); }
};

struct ViewClass {
  int id;                 ///< 1..11
  CoronarySystem system;  ///< the injected system this view is routine for
  const char* name;       ///< e.g. "LAO Cranial"
  AngleRange primary;     ///< degrees, +LAO / -RAO
  AngleRange secondary;   ///< degrees, +cranial / -caudal
};

constexpr double kViewJitterDeg = 5.0;
constexpr int kUnknownViewClass = 0;
constexpr int kNumViewClassIds = 12;  ///< 11 classes + unknown

inline const std::array<ViewClass, 11>& routine_views() {
  static const std::array<ViewClass, 11> views = {{
      {1, CoronarySystem::RCA, "AP Cranial", {0, 0}, {15, 30}},
      {2, CoronarySystem::RCA, "LAO", {40, 60}, {0, 0}},
      {3, CoronarySystem::RCA, "LAO Cranial", {30, 50}, {10, 25}},
      {4, CoronarySystem::RCA, "RAO", {-40, -20}, {0, 15}},
      {5, CoronarySystem::LCA, "AP", {0, 0}, {0, 0}},
      {6, CoronarySystem::LCA, "AP Cranial", {0, 0}, {15, 30}},
      {7, CoronarySystem::LCA, "AP Caudal", {0, 0}, {-30, -20}},
      {8, CoronarySystem::LCA, "LAO Cranial", {30, 60}, {15, 30}},
      {9, CoronarySystem::LCA, "LAO Caudal", {35, 55}, {-35, -20}},
      {10, CoronarySystem::LCA, "RAO Cranial", {-40, -20}, {15, 30}},
      {11, CoronarySystem::LCA, "RAO Caudal", {-25, -10}, {-25, -15}},
  }};
  return views;
}

/// The view class with id 1..11; throws for anything else.
inline const ViewClass& view_class(int id) {
  GIMM_CHECK(id >= 1 && id <= 11, "view class id must be in 1..11, got " << id);
  return routine_views()[static_cast<std::size_t>(id - 1)];
}

/// The view classes of one system, in id order (4 for RCA, 7 for LCA).
inline std::vector<ViewClass> views_of(CoronarySystem system) {
  std::vector<ViewClass> out;
  for (const auto& v : routine_views())
    if (v.system == system) out.push_back(v);
  return out;
}

}  // namespace gimm
