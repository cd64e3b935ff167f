#pragma once
/// Sampling the clinical view protocol (views.hpp): jittered angles per view class, and the
/// view pairs of one injected system.
///
/// Two modes, both from reference-notes.md:
///   shared   - one render per view class (4 RCA + 7 LCA = 11 per patient), and every unordered
///              pair of a system's classes reuses those renders (the paper's text);
///   per_pair - every pair draws fresh angles for both of its views (the released code:
///              2 x (6 + 21) = 54 renders per patient).
/// Angles are drawn uniformly from each class's range widened by kViewJitterDeg on both sides.
#include <cstdint>
#include <string>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/core/rng.hpp"
#include "gimm/labels/views.hpp"

namespace gimm {

enum class ViewMode { shared, per_pair };

inline ViewMode parse_view_mode(const std::string& name) {
  if (name == "shared") return ViewMode::shared;
  if (name == "per_pair" || name == "per-pair") return ViewMode::per_pair;
  GIMM_FAIL("view mode must be shared|per_pair, got '" << name << "'");
}
inline const char* to_string(ViewMode m) {
  return m == ViewMode::shared ? "shared" : "per_pair";
}

/// One view to render: its class and the drawn C-arm angles.
struct SampledView {
  int view_class = kUnknownViewClass;
  double primary_deg = 0;
  double secondary_deg = 0;
};

inline SampledView sample_view(const ViewClass& view, Rng& rng,
                               double jitter_deg = kViewJitterDeg) {
  GIMM_CHECK(jitter_deg >= 0 && jitter_deg < 30,
             "sample_view: jitter must be in [0, 30) degrees, got " << jitter_deg);
  SampledView out;
  out.view_class = view.id;
  out.primary_deg = rng.uniform(view.primary.lo - jitter_deg, view.primary.hi + jitter_deg);
  out.secondary_deg = rng.uniform(view.secondary.lo - jitter_deg, view.secondary.hi + jitter_deg);
  return out;
}

/// A pair of views of one system; `a` and `b` index into ViewPlan::views.
struct ViewPairIndex {
  std::size_t a;
  std::size_t b;
};

struct ViewPlan {
  CoronarySystem system;
  std::vector<SampledView> views;    ///< every render this system needs
  std::vector<ViewPairIndex> pairs;  ///< all unordered pairs of the system's classes
};

/// The renders and pairs of one system. Pairs are ordered by (class A, class B), A < B.
inline ViewPlan plan_views(CoronarySystem system, ViewMode mode, Rng& rng,
                           double jitter_deg = kViewJitterDeg) {
  const std::vector<ViewClass> classes = views_of(system);
  ViewPlan plan{system, {}, {}};
  if (mode == ViewMode::shared) {
    for (const auto& c : classes) plan.views.push_back(sample_view(c, rng, jitter_deg));
    for (std::size_t a = 0; a < classes.size(); ++a)
      for (std::size_t b = a + 1; b < classes.size(); ++b) plan.pairs.push_back({a, b});
    return plan;
  }
  for (std::size_t a = 0; a < classes.size(); ++a)
    for (std::size_t b = a + 1; b < classes.size(); ++b) {
      plan.views.push_back(sample_view(classes[a], rng, jitter_deg));
      plan.views.push_back(sample_view(classes[b], rng, jitter_deg));
      plan.pairs.push_back({plan.views.size() - 2, plan.views.size() - 1});
    }
  return plan;
}

}  // namespace gimm
