#pragma once
/// The clinical view protocol of the released dataset (reference-notes.md): 11 view classes,
/// their C-arm angle ranges, and the coronary system each belongs to.
///
/// Class ids are 1..11 in table order; 0 means unknown (the matcher's 12th embedding row).
/// Angles in degrees: primary +LAO / -RAO, secondary +cranial / -caudal. When sampling, each
/// range is widened by kViewJitterDeg on both sides and drawn uniformly.
#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "gimm/anatomy/coronary_system.hpp"
#include "gimm/core/error.hpp"
#include "gimm/geometry/carm.hpp"

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

/// The view class nearest to a C-arm pose, and how far the pose is from it.
struct ViewClassMatch {
  int id = kUnknownViewClass;
  double distance_deg = 0;  ///< 0 inside the class's angle ranges
};

/// The angle between the viewing directions of two poses, degrees.
inline double view_angle_between(double primary_a, double secondary_a, double primary_b,
                                 double secondary_b) {
  CArm a, b;
  a.primary_deg = primary_a;
  a.secondary_deg = secondary_a;
  b.primary_deg = primary_b;
  b.secondary_deg = secondary_b;
  const double c = std::clamp(a.source_direction().dot(b.source_direction()), -1.0, 1.0);
  return rad_to_deg(std::acos(c));
}

/// The routine view class nearest to (primary, secondary), among the classes of `system` (all
/// eleven when it is not given). The distance to a class is the angle between the pose's view
/// direction and that of the nearest pose within the class's ranges (the angles clamped into
/// them), so it is 0 inside; ties (overlapping ranges) go to the nearer class centre.
inline ViewClassMatch view_class_from_angles(std::optional<CoronarySystem> system,
                                             double primary_deg, double secondary_deg) {
  GIMM_CHECK(std::isfinite(primary_deg) && std::isfinite(secondary_deg),
             "view_class_from_angles: angles must be finite, got " << primary_deg << ", "
                                                                   << secondary_deg);
  ViewClassMatch best;
  double best_centre = 0;
  for (const auto& view : routine_views()) {
    if (system && view.system != *system) continue;
    const double p = std::clamp(primary_deg, view.primary.lo, view.primary.hi);
    const double s = std::clamp(secondary_deg, view.secondary.lo, view.secondary.hi);
    const bool inside = p == primary_deg && s == secondary_deg;
    const double distance = inside ? 0.0 : view_angle_between(primary_deg, secondary_deg, p, s);
    const double centre = view_angle_between(primary_deg, secondary_deg, view.primary.centre(),
                                             view.secondary.centre());
    if (best.id == kUnknownViewClass || distance < best.distance_deg - 1e-9 ||
        (distance < best.distance_deg + 1e-9 && centre < best_centre)) {
      best = {view.id, distance};
      best_centre = centre;
    }
  }
  return best;
}

}  // namespace gimm
