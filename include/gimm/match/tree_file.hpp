#pragma once
/// gimm-tree/1: the triangulated points of one matched pair (gimm-match --tree writes it,
/// gimm-eval --tree reads it). One writer and one reader, the format checked on read.
///
///   {"format": "gimm-tree/1",
///    "points": [{"a": [u, v], "b": [u, v], "world_mm": [x, y, z], "confidence": c,
///                "reprojection_px": [e_a, e_b],        (learned matcher: reprojection errors)
///                "branch": k, "consistent": true},      (geometric matcher: A branch, check)
///               ...],
///    "dropped_degenerate": n, "dropped_reprojection": n}  (learned matcher: points not kept)
/// Pixels with centres at integers, u = column; world in patient mm (LPS).
#include <Eigen/Core>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/io/files.hpp"

namespace gimm {

constexpr const char* kTreeFormat = "gimm-tree/1";

struct TreePoint {
  Eigen::Vector2d a = Eigen::Vector2d::Zero(), b = Eigen::Vector2d::Zero();  ///< pixels
  Eigen::Vector3d world = Eigen::Vector3d::Zero();                           ///< mm
  double confidence = 0;
  std::optional<Eigen::Vector2d> reprojection_px;  ///< in A and in B
  std::optional<int> branch;                       ///< the A branch it lies on
  std::optional<bool> consistent;
};

struct TreeFile {
  std::vector<TreePoint> points;
  std::optional<std::size_t> dropped_degenerate, dropped_reprojection;
};

inline nlohmann::json to_json(const TreeFile& tree) {
  nlohmann::json points = nlohmann::json::array();
  for (const TreePoint& p : tree.points) {
    nlohmann::json j = {{"a", {p.a.x(), p.a.y()}},
                        {"b", {p.b.x(), p.b.y()}},
                        {"world_mm", {p.world.x(), p.world.y(), p.world.z()}},
                        {"confidence", p.confidence}};
    if (p.reprojection_px) j["reprojection_px"] = {p.reprojection_px->x(), p.reprojection_px->y()};
    if (p.branch) j["branch"] = *p.branch;
    if (p.consistent) j["consistent"] = *p.consistent;
    points.push_back(std::move(j));
  }
  nlohmann::json j = {{"format", kTreeFormat}, {"points", std::move(points)}};
  if (tree.dropped_degenerate) j["dropped_degenerate"] = *tree.dropped_degenerate;
  if (tree.dropped_reprojection) j["dropped_reprojection"] = *tree.dropped_reprojection;
  return j;
}

inline void write_tree_file(const std::filesystem::path& path, const TreeFile& tree) {
  write_json_file(path, to_json(tree));
}

namespace detail {

/// `key` of point `k`: an array of N finite numbers.
template <int N>
Eigen::Matrix<double, N, 1> tree_vector(const nlohmann::json& point, const char* key, std::size_t k,
                                        const std::string& where) {
  const nlohmann::json* v = point.contains(key) ? &point.at(key) : nullptr;
  GIMM_CHECK_AS(FormatError, v && v->is_array() && v->size() == N,
                where << ": points[" << k << "]." << key << " must be " << N << " numbers, got "
                      << (v ? v->dump() : std::string("nothing")));
  Eigen::Matrix<double, N, 1> out;
  for (int i = 0; i < N; ++i) {
    const nlohmann::json& x = (*v)[i];
    GIMM_CHECK_AS(FormatError, x.is_number() && std::isfinite(x.get<double>()),
                  where << ": points[" << k << "]." << key << " holds " << x.dump()
                        << ", not a finite number");
    out[i] = x.get<double>();
  }
  return out;
}

inline std::size_t tree_count(const nlohmann::json& j, const char* key, const std::string& where) {
  const nlohmann::json& v = j.at(key);
  GIMM_CHECK_AS(FormatError, v.is_number_unsigned(),
                where << ": " << key << " must be a count, got " << v.dump());
  return v.get<std::size_t>();
}

}  // namespace detail

inline TreeFile tree_file_from_json(const nlohmann::json& j, const std::string& where) {
  GIMM_CHECK_AS(FormatError, j.is_object() && j.contains("format") && j.at("format").is_string(),
                where << ": not a " << kTreeFormat << " file (a reconstructed tree): no 'format'");
  GIMM_CHECK_AS(
      FormatError, j.at("format") == kTreeFormat,
      where << ": format " << j.at("format").dump() << ", gimm reads \"" << kTreeFormat << "\"");
  GIMM_CHECK_AS(FormatError, j.contains("points") && j.at("points").is_array(),
                where << ": 'points' must be an array");
  TreeFile tree;
  const nlohmann::json& points = j.at("points");
  for (std::size_t k = 0; k < points.size(); ++k) {
    const nlohmann::json& p = points[k];
    GIMM_CHECK_AS(FormatError, p.is_object(),
                  where << ": points[" << k << "] must be an object, got " << p.dump());
    TreePoint t;
    t.a = detail::tree_vector<2>(p, "a", k, where);
    t.b = detail::tree_vector<2>(p, "b", k, where);
    t.world = detail::tree_vector<3>(p, "world_mm", k, where);
    if (p.contains("confidence")) {
      const nlohmann::json& c = p.at("confidence");
      GIMM_CHECK_AS(
          FormatError, c.is_number() && std::isfinite(c.get<double>()),
          where << ": points[" << k << "].confidence must be a finite number, got " << c.dump());
      t.confidence = c.get<double>();
    }
    if (p.contains("reprojection_px"))
      t.reprojection_px = detail::tree_vector<2>(p, "reprojection_px", k, where);
    if (p.contains("branch")) {
      const nlohmann::json& b = p.at("branch");
      GIMM_CHECK_AS(
          FormatError,
          b.is_number_unsigned()
              ? b.get<std::uint64_t>() <= std::uint64_t(std::numeric_limits<int>::max())
              : b.is_number_integer() && b.get<std::int64_t>() == -1,
          where << ": points[" << k << "].branch must be an index (-1: none), got " << b.dump());
      t.branch = static_cast<int>(b.get<std::int64_t>());
    }
    if (p.contains("consistent")) {
      GIMM_CHECK_AS(FormatError, p.at("consistent").is_boolean(),
                    where << ": points[" << k << "].consistent must be true or false, got "
                          << p.at("consistent").dump());
      t.consistent = p.at("consistent").get<bool>();
    }
    tree.points.push_back(t);
  }
  if (j.contains("dropped_degenerate"))
    tree.dropped_degenerate = detail::tree_count(j, "dropped_degenerate", where);
  if (j.contains("dropped_reprojection"))
    tree.dropped_reprojection = detail::tree_count(j, "dropped_reprojection", where);
  return tree;
}

inline TreeFile read_tree_file(const std::filesystem::path& path) {
  return tree_file_from_json(read_json_file(path), path.string());
}

}  // namespace gimm
