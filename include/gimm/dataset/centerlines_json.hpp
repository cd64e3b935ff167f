#pragma once
/// Centerline trees as JSON:
///   {"units": "mm", "frame": "LPS",
///    "branches": [{"name": "LAD", "system": "LCA", "parent": 0,
///                  "points": [[x, y, z], ...], "radius": [r, ...]}, ...]}
/// `parent` is an index into "branches" (-1 for a root). Extra top-level keys are kept by
/// callers (the phantom adds its anatomy record).
#include <limits>
#include <nlohmann/json.hpp>
#include <string>

#include "gimm/anatomy/centerlines.hpp"
#include "gimm/anatomy/lumen.hpp"
#include "gimm/anatomy/tortuosity.hpp"
#include "gimm/io/files.hpp"

namespace gimm {

/// A phantom's lumen as drawn: {"irregularity": sigma, "irregularity_mm": mm, "stenoses":
/// [{"branch": "LAD", "at_mm": arc length from the branch's start, "length_mm", "severity":
/// diameter reduction 0..1}, ...]}.
inline nlohmann::json lumen_json(const LumenOptions& o, const std::vector<Stenosis>& drawn) {
  nlohmann::json stenoses = nlohmann::json::array();
  for (const Stenosis& s : drawn)
    stenoses.push_back({{"branch", s.branch},
                        {"at_mm", s.at_mm},
                        {"length_mm", s.length_mm},
                        {"severity", s.severity}});
  return {{"irregularity", o.irregularity},
          {"irregularity_mm", o.irregularity_mm},
          {"stenoses", stenoses}};
}

/// A phantom's irregular course: {"sigma_mm": lateral sd, "correlation_mm": along the vessel}.
inline nlohmann::json tortuosity_json(const TortuosityOptions& o) {
  return {{"sigma_mm", o.sigma_mm}, {"correlation_mm", o.correlation_mm}};
}

inline nlohmann::json to_json(const CenterlineTree& tree) {
  nlohmann::json branches = nlohmann::json::array();
  for (const auto& br : tree.branches) {
    nlohmann::json points = nlohmann::json::array();
    for (const auto& p : br.points) points.push_back({p.x(), p.y(), p.z()});
    branches.push_back({{"name", br.name},
                        {"system", to_string(br.system)},
                        {"parent", br.parent},
                        {"points", points},
                        {"radius", br.radii}});
  }
  return {{"units", "mm"}, {"frame", "LPS"}, {"branches", branches}};
}

/// Parses and validates; errors name `what` (the file) and the bad branch or field.
inline CenterlineTree centerlines_from_json(const nlohmann::json& j, const std::string& what) {
  CenterlineTree tree;
  try {
    GIMM_CHECK_AS(FormatError, j.value("frame", "LPS") == "LPS" && j.value("units", "mm") == "mm",
                  what << ": centerlines must be in LPS mm");
    for (const auto& b : j.at("branches")) {
      CenterlineBranch br;
      br.name = b.at("name").get<std::string>();
      try {
        br.system = parse_coronary_system(b.at("system").get<std::string>());
      } catch (const nlohmann::json::exception&) {
        throw;
      } catch (const Error& e) {  // its message names no file
        throw FormatError("gimm: " + what + ": branch '" + br.name +
                          "': " + std::string(e.what()).substr(6));
      }
      const nlohmann::json& parent = b.at("parent");
      GIMM_CHECK_AS(FormatError, json_int_in(parent, -1, std::numeric_limits<int>::max()),
                    what << ": branch '" << br.name
                         << "': 'parent' must be a branch index or -1, got " << parent.dump());
      br.parent = parent.get<int>();
      for (const auto& p : b.at("points")) {
        GIMM_CHECK_AS(FormatError, p.is_array() && p.size() == 3,
                      what << ": branch '" << br.name << "' has a point that is not [x, y, z]");
        br.points.emplace_back(p[0].get<double>(), p[1].get<double>(), p[2].get<double>());
      }
      br.radii = b.at("radius").get<std::vector<double>>();
      tree.branches.push_back(std::move(br));
    }
  } catch (const nlohmann::json::exception& e) {
    throw FormatError("gimm: " + what + ": malformed centerlines: " + e.what());
  }
  // An empty tree scores as an infinite distance and every figure '-': refuse it.
  GIMM_CHECK_AS(FormatError, !tree.branches.empty(), what << ": the tree has no branches");
  try {
    tree.validate(what);
  } catch (const Error& e) {
    throw FormatError(e.what());
  }
  return tree;
}

inline CenterlineTree read_centerlines(const std::filesystem::path& path) {
  return centerlines_from_json(read_json_file(path), "'" + path.string() + "'");
}

}  // namespace gimm
