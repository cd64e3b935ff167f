#pragma once
/// Predicted matches of one view pair, and their JSON file format (docs/evaluation.md).
///
/// One file per pair, PRED_DIR/<patient>/<pair>.json, where <pair> is the stem of the dataset's
/// pair file (e.g. PRED_DIR/phantom-0000/LCA_00-01.json):
///
///   {"format": "gimm-matches/1",                      (optional on reading)
///    "pair": "phantom-0000/LCA_00-01",                (<patient>/<pair stem>)
///    "points_a": [[u, v], ...],                       (pixels in view A, u = column, v = row,
///    "points_b": [[u, v], ...],                        pixel centres at integers)
///    "confidence": [c, ...],                          (optional: all 1 when missing)
///    "F": [[..3] x3], "F_source": "cameras"|"matches"} (optional: the F the matches were gated
///                                                      with, x_b^T F x_a = 0, and its origin)
///
/// Match i is points_a[i] <-> points_b[i]; a higher confidence ranks first. Coordinates and
/// confidences must be finite numbers and the three arrays equally long (possibly empty).
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <numeric>
#include <optional>
#include <string>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/io/files.hpp"

namespace gimm {

constexpr const char* kMatchesFormat = "gimm-matches/1";

struct PairMatches {
  std::string pair;  ///< "<patient>/<pair stem>"
  std::vector<Eigen::Vector2d> points_a;
  std::vector<Eigen::Vector2d> points_b;
  std::vector<double> confidence;
  std::optional<Eigen::Matrix3d> F;  ///< the F used for gating, when written with the matches
  std::string F_source;              ///< "cameras" (exact) or "matches" (estimated)

  std::size_t size() const { return points_a.size(); }

  void add(const Eigen::Vector2d& a, const Eigen::Vector2d& b, double c) {
    points_a.push_back(a);
    points_b.push_back(b);
    confidence.push_back(c);
  }

  /// Throws unless the arrays are equally long and every number is finite.
  void validate(const std::string& where) const {
    GIMM_CHECK_AS(FormatError,
                  points_b.size() == points_a.size() && confidence.size() == points_a.size(),
                  where << ": points_a, points_b and confidence have " << points_a.size() << ", "
                        << points_b.size() << " and " << confidence.size()
                        << " entries; they must be equally long");
    for (std::size_t i = 0; i < size(); ++i)
      GIMM_CHECK_AS(
          FormatError,
          points_a[i].allFinite() && points_b[i].allFinite() && std::isfinite(confidence[i]),
          where << ": match " << i << " has a non-finite coordinate or confidence");
  }
};

/// Match indices by descending confidence, ties by ascending index; at most `k` of them
/// (k < 0: all).
inline std::vector<std::size_t> rank_by_confidence(const std::vector<double>& confidence,
                                                   long k = -1) {
  std::vector<std::size_t> idx(confidence.size());
  std::iota(idx.begin(), idx.end(), std::size_t{0});
  std::stable_sort(idx.begin(), idx.end(), [&](std::size_t a, std::size_t b) {
    return confidence[a] > confidence[b];  // stable: equal confidences keep index order
  });
  if (k >= 0 && static_cast<std::size_t>(k) < idx.size()) idx.resize(static_cast<std::size_t>(k));
  return idx;
}

inline nlohmann::json to_json(const PairMatches& m) {
  nlohmann::json a = nlohmann::json::array(), b = nlohmann::json::array();
  for (const auto& p : m.points_a) a.push_back({p.x(), p.y()});
  for (const auto& p : m.points_b) b.push_back({p.x(), p.y()});
  nlohmann::json j = {{"format", kMatchesFormat},
                      {"pair", m.pair},
                      {"points_a", a},
                      {"points_b", b},
                      {"confidence", m.confidence}};
  if (m.F) {
    nlohmann::json rows = nlohmann::json::array();
    for (int r = 0; r < 3; ++r) rows.push_back({(*m.F)(r, 0), (*m.F)(r, 1), (*m.F)(r, 2)});
    j["F"] = rows;
    j["F_source"] = m.F_source;
  }
  return j;
}

namespace detail {

inline std::vector<Eigen::Vector2d> points_from_json(const nlohmann::json& j, const char* key,
                                                     const std::string& where) {
  GIMM_CHECK_AS(FormatError, j.contains(key) && j.at(key).is_array(),
                where << ": missing array '" << key << "'");
  std::vector<Eigen::Vector2d> out;
  for (const auto& p : j.at(key)) {
    GIMM_CHECK_AS(
        FormatError, p.is_array() && p.size() == 2 && p[0].is_number() && p[1].is_number(),
        where << ": '" << key << "' entry " << out.size() << " must be [u, v], got " << p.dump());
    out.emplace_back(p[0].get<double>(), p[1].get<double>());
  }
  return out;
}

}  // namespace detail

inline PairMatches matches_from_json(const nlohmann::json& j, const std::string& where) {
  GIMM_CHECK_AS(FormatError, j.is_object(), where << ": a matches file must be a JSON object");
  if (j.contains("format"))
    GIMM_CHECK_AS(FormatError, j.at("format") == kMatchesFormat,
                  where << ": format is " << j.at("format").dump() << ", expected \""
                        << kMatchesFormat << "\"");
  PairMatches m;
  if (j.contains("pair")) {
    GIMM_CHECK_AS(FormatError, j.at("pair").is_string(), where << ": 'pair' must be a string");
    m.pair = j.at("pair").get<std::string>();
  }
  m.points_a = detail::points_from_json(j, "points_a", where);
  m.points_b = detail::points_from_json(j, "points_b", where);
  if (j.contains("confidence") && !j.at("confidence").is_null()) {
    GIMM_CHECK_AS(FormatError, j.at("confidence").is_array(),
                  where << ": 'confidence' must be an array of numbers");
    for (const auto& c : j.at("confidence")) {
      GIMM_CHECK_AS(FormatError, c.is_number(),
                    where << ": 'confidence' has a non-number " << c.dump());
      m.confidence.push_back(c.get<double>());
    }
  } else {
    m.confidence.assign(m.points_a.size(), 1.0);
  }
  if (j.contains("F")) {
    const nlohmann::json& f = j.at("F");
    GIMM_CHECK_AS(FormatError, f.is_array() && f.size() == 3,
                  where << ": 'F' must be 3 rows of 3 numbers, got " << f.dump());
    Eigen::Matrix3d F;
    for (int r = 0; r < 3; ++r) {
      GIMM_CHECK_AS(FormatError, f[r].is_array() && f[r].size() == 3,
                    where << ": 'F' row " << r << " must be 3 numbers, got " << f[r].dump());
      for (int c = 0; c < 3; ++c) {
        GIMM_CHECK_AS(FormatError, f[r][c].is_number() && std::isfinite(f[r][c].get<double>()),
                      where << ": 'F' has a non-number " << f[r][c].dump());
        F(r, c) = f[r][c].get<double>();
      }
    }
    m.F = F;
    m.F_source = "unknown";
    if (j.contains("F_source")) {
      GIMM_CHECK_AS(FormatError, j.at("F_source").is_string(),
                    where << ": 'F_source' must be a string, got " << j.at("F_source").dump());
      m.F_source = j.at("F_source").get<std::string>();
    }
  }
  m.validate(where);
  return m;
}

/// PRED_DIR/<patient>/<pair stem>.json for pair id "<patient>/<pair stem>".
inline std::filesystem::path matches_path(const std::filesystem::path& pred_dir,
                                          const std::string& pair_id) {
  return pred_dir / (pair_id + ".json");
}

inline void write_matches(const std::filesystem::path& path, const PairMatches& m) {
  m.validate(path.string());
  if (path.has_parent_path()) create_folders(path.parent_path());  // WriteError, named
  write_json_file(path, to_json(m), -1);
}

/// Reads one matches file; a missing 'pair' field is taken from the file's place
/// (<patient>/<stem>), a present one must agree with it.
inline PairMatches read_matches(const std::filesystem::path& path) {
  PairMatches m = matches_from_json(read_json_file(path), path.string());
  const std::string from_path = path.parent_path().filename().string() + "/" + path.stem().string();
  if (m.pair.empty()) m.pair = from_path;
  GIMM_CHECK_AS(FormatError, m.pair == from_path,
                path.string() << ": 'pair' is \"" << m.pair << "\" but the file's place says \""
                              << from_path << "\"");
  return m;
}

}  // namespace gimm
