#pragma once
/// Views placed on purpose (gimm-dataset --views FILE): pairs of C-arm poses that the protocol's
/// jittered class ranges never give, e.g. two views 5 degrees apart for a sweep of the angle
/// between the views (docs/stability.md). Each pose gets the routine view class of its system
/// nearest to it (view_class_from_angles): the learned matcher embeds the class.
///
/// File format "gimm-views/1", angles in degrees (+LAO / -RAO, +cranial / -caudal):
///   {"format": "gimm-views/1",
///    "pairs": [{"system": "LCA", "a": {"primary": 30, "secondary": 0},
///                                "b": {"primary": 35, "secondary": 0}}, ...]}
/// A pose used by several pairs of one system is rendered once; pairs keep the file's order; a
/// pair listed twice is refused. A top-level "note" (free text) is allowed and ignored.
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "gimm/anatomy/coronary_system.hpp"
#include "gimm/core/error.hpp"
#include "gimm/io/files.hpp"
#include "gimm/labels/view_protocol.hpp"
#include "gimm/labels/views.hpp"

namespace gimm {

inline constexpr const char* kViewListFormat = "gimm-views/1";

/// Two views closer than this give an epipolar geometry too close to degenerate to label or
/// match (the baseline vanishes); such a pair is refused rather than rendered.
constexpr double kMinListedSeparationDeg = 1.0;

/// One listed pair; both views carry the class nearest to their angles.
struct ListedPair {
  CoronarySystem system = CoronarySystem::LCA;
  SampledView a, b;
};

/// Two listed poses are one view when their angles are equal (a shared pose renders once).
inline bool same_pose(const SampledView& x, const SampledView& y) {
  return x.primary_deg == y.primary_deg && x.secondary_deg == y.secondary_deg;
}

namespace detail {

/// Refuses keys a reader would silently ignore (a typo such as "secundary").
inline void check_keys(const nlohmann::json& j, std::initializer_list<const char*> allowed,
                       const std::string& where) {
  for (const auto& item : j.items()) {
    bool known = false;
    for (const char* key : allowed) known = known || item.key() == key;
    GIMM_CHECK_AS(FormatError, known, where << ": unknown field '" << item.key() << "'");
  }
}

inline SampledView listed_pose(const nlohmann::json& j, CoronarySystem system,
                               const std::string& where) {
  GIMM_CHECK_AS(
      FormatError, j.is_object(),
      where << ": a pose must be an object {\"primary\", \"secondary\"}, got " << j.dump());
  check_keys(j, {"primary", "secondary"}, where);
  SampledView v;
  v.primary_deg = json_number(j, "primary", where);
  v.secondary_deg = json_number(j, "secondary", where);
  // The C-arm's own limits (CArm::validate), checked here so the message names the file.
  GIMM_CHECK_AS(FormatError, std::abs(v.primary_deg) <= 180,
                where << ": 'primary' must be in [-180, 180] degrees, got " << v.primary_deg);
  GIMM_CHECK_AS(FormatError, std::abs(v.secondary_deg) < 90,
                where << ": 'secondary' must be in (-90, 90) degrees, got " << v.secondary_deg);
  v.view_class = view_class_from_angles(system, v.primary_deg, v.secondary_deg).id;
  return v;
}

}  // namespace detail

/// The pairs of a parsed "gimm-views/1" document; `where` names it in errors (FormatError).
inline std::vector<ListedPair> view_list_from_json(const nlohmann::json& doc,
                                                   const std::string& where) {
  GIMM_CHECK_AS(FormatError, doc.is_object(), where << ": must be a JSON object");
  detail::check_keys(doc, {"format", "pairs", "note"}, where);
  GIMM_CHECK_AS(FormatError, !doc.contains("note") || doc.at("note").is_string(),
                where << ": 'note' is free text, a string; got " << doc.at("note").dump());
  const std::string format = json_string(doc, "format", where);
  GIMM_CHECK_AS(FormatError, format == kViewListFormat,
                where << ": 'format' must be '" << kViewListFormat << "', got '" << format << "'");
  const nlohmann::json& pairs = json_field(doc, "pairs", where);
  GIMM_CHECK_AS(FormatError, pairs.is_array() && !pairs.empty(),
                where << ": 'pairs' must be a non-empty array, got " << pairs.dump());
  std::vector<ListedPair> out;
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const std::string at = where + ": pairs[" + std::to_string(i) + "]";
    const nlohmann::json& p = pairs[i];
    GIMM_CHECK_AS(FormatError, p.is_object(), at << ": must be an object, got " << p.dump());
    detail::check_keys(p, {"system", "a", "b"}, at);
    ListedPair pair;
    const std::string system = json_string(p, "system", at);
    GIMM_CHECK_AS(FormatError, system == "RCA" || system == "LCA",
                  at << ": 'system' must be RCA or LCA, got '" << system << "'");
    pair.system = parse_coronary_system(system);
    pair.a = detail::listed_pose(json_field(p, "a", at), pair.system, at + ".a");
    pair.b = detail::listed_pose(json_field(p, "b", at), pair.system, at + ".b");
    const double separation = view_angle_between(pair.a.primary_deg, pair.a.secondary_deg,
                                                 pair.b.primary_deg, pair.b.secondary_deg);
    // 1e-9 of slack: 30 and 31 degrees come out 0.99999999... apart in floating point.
    GIMM_CHECK_AS(FormatError, separation >= kMinListedSeparationDeg - 1e-9,
                  at << ": views a and b are " << separation << " degrees apart; at least "
                     << kMinListedSeparationDeg << " is needed for an epipolar geometry");
    // A pair listed twice (in either order) would write one pair file twice and count it twice.
    for (std::size_t k = 0; k < out.size(); ++k) {
      const ListedPair& q = out[k];
      const bool twice =
          q.system == pair.system && ((same_pose(q.a, pair.a) && same_pose(q.b, pair.b)) ||
                                      (same_pose(q.a, pair.b) && same_pose(q.b, pair.a)));
      GIMM_CHECK_AS(FormatError, !twice, at << ": the same pair as pairs[" << k << "]");
    }
    out.push_back(pair);
  }
  return out;
}

/// Reads a "gimm-views/1" file.
inline std::vector<ListedPair> read_view_list(const std::filesystem::path& path) {
  return view_list_from_json(read_json_file(path), "view list '" + path.string() + "'");
}

/// The list as the dataset's manifest records it (the file's format; classes left out, they
/// follow from the angles).
inline nlohmann::json view_list_to_json(const std::vector<ListedPair>& pairs) {
  const auto pose = [](const SampledView& v) {
    return nlohmann::json{{"primary", v.primary_deg}, {"secondary", v.secondary_deg}};
  };
  nlohmann::json list = nlohmann::json::array();
  for (const auto& p : pairs)
    list.push_back({{"system", to_string(p.system)}, {"a", pose(p.a)}, {"b", pose(p.b)}});
  return {{"format", kViewListFormat}, {"pairs", list}};
}

/// The renders and pairs of one system from a list: each distinct pose once, in order of first
/// use; the pairs in the list's order. A system the list does not name has no views.
inline ViewPlan plan_listed_views(CoronarySystem system, const std::vector<ListedPair>& pairs) {
  ViewPlan plan{system, {}, {}};
  const auto index_of = [&plan](const SampledView& v) {
    for (std::size_t i = 0; i < plan.views.size(); ++i)
      if (same_pose(plan.views[i], v)) return i;
    plan.views.push_back(v);
    return plan.views.size() - 1;
  };
  for (const auto& p : pairs)
    if (p.system == system) {
      const std::size_t a = index_of(p.a);
      plan.pairs.push_back({a, index_of(p.b)});
    }
  return plan;
}

}  // namespace gimm
