#pragma once
/// A user's own sparse ground truth for one image pair, scored with the reference protocol
/// without a gimm dataset (gimm-eval --truth T.json --predictions P.json).
///
/// Format (docs/evaluation.md), pixels with centres at integers, u = column:
///   {"format": "gimm-truth/1",                       (optional on reading)
///    "pair": "name",                                 (optional: the file's stem)
///    "points_a": [[u, v], ...], "points_b": [[u, v], ...],   (point i of A <-> point i of B)
///    "world_mm": [[x, y, z], ...],                   (optional: enables the 3D error)
///    "F": [[..3] x3]}                                (optional: the epipolar column, x_b^T F x_a)
/// The protocol scores a match where its source point is on the vessel mask. Sparse truth has
/// no mask, so its mask is the discs of `radius_px` around the truth points: a match whose
/// source point is further than that from every truth point cannot be checked and is not scored
/// (it lowers the coverage instead).
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "gimm/core/error.hpp"
#include "gimm/core/image.hpp"
#include "gimm/dataset/reader.hpp"
#include "gimm/io/camera_json.hpp"
#include "gimm/io/files.hpp"
#include "gimm/match/matches.hpp"

namespace gimm {

constexpr const char* kTruthFormat = "gimm-truth/1";
/// Truth points lie on a detector: at most the C-arm's largest (16384 px, CArm::validate), so a
/// stray coordinate cannot ask for a mask of gigabytes (or overflow its int size).
constexpr double kMaxTruthPixel = 16384;
/// The largest truth radius: a disc wider than this is no longer "at the truth point".
constexpr double kMaxTruthRadius = 256;

/// Sparse truth's stand-in for a vessel mask: the discs of `radius` px around `points`, on an
/// image just large enough to hold them (for truth built in memory, as read_user_truth does).
inline std::shared_ptr<const Image<std::uint8_t>> sparse_truth_mask(
    const std::vector<Eigen::Vector2d>& points, double radius) {
  double max_u = 0, max_v = 0;
  for (const auto& p : points) {
    max_u = std::max(max_u, p.x());
    max_v = std::max(max_v, p.y());
  }
  const int cols = int(std::ceil(max_u + radius)) + 1, rows = int(std::ceil(max_v + radius)) + 1;
  auto mask = std::make_shared<Image<std::uint8_t>>(rows, cols);
  const int r = int(std::ceil(radius));
  for (const auto& p : points)
    for (int dv = -r; dv <= r; ++dv)
      for (int du = -r; du <= r; ++du) {
        const long row = std::lround(p.y()) + dv, col = std::lround(p.x()) + du;
        if (row < 0 || col < 0 || row >= rows || col >= cols) continue;
        if (std::hypot(double(col) - p.x(), double(row) - p.y()) <= radius)
          (*mask)(int(row), int(col)) = 255;
      }
  return mask;
}

inline PairTruth read_user_truth(const std::filesystem::path& path, double radius_px) {
  GIMM_CHECK(std::isfinite(radius_px) && radius_px > 0 && radius_px <= kMaxTruthRadius,
             "the truth radius must be in (0, " << kMaxTruthRadius << "] px, got " << radius_px);
  const nlohmann::json j = read_json_file(path);
  const std::string where = path.string();
  GIMM_CHECK_AS(FormatError, j.is_object(), where << ": a truth file must be a JSON object");
  if (j.contains("format"))
    GIMM_CHECK_AS(FormatError, j.at("format") == kTruthFormat,
                  where << ": format is " << j.at("format").dump() << ", expected \""
                        << kTruthFormat << "\"");
  PairTruth t;
  t.id = path.stem().string();
  if (j.contains("pair")) {
    GIMM_CHECK_AS(FormatError, j.at("pair").is_string(), where << ": 'pair' must be a string");
    t.id = j.at("pair").get<std::string>();
  }
  const auto a = detail::points_from_json(j, "points_a", where);
  const auto b = detail::points_from_json(j, "points_b", where);
  GIMM_CHECK_AS(FormatError, a.size() == b.size() && !a.empty(),
                where << ": 'points_a' and 'points_b' must be equally long and not empty (got "
                      << a.size() << " and " << b.size() << ")");
  std::vector<Eigen::Vector3d> world(
      a.size(), Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN()));
  if (j.contains("world_mm")) {
    const nlohmann::json& w = j.at("world_mm");
    GIMM_CHECK_AS(FormatError, w.is_array() && w.size() == a.size(),
                  where << ": 'world_mm' must hold one [x, y, z] per point (" << a.size() << ")");
    for (std::size_t k = 0; k < a.size(); ++k) {
      GIMM_CHECK_AS(
          FormatError, w[k].is_array() && w[k].size() == 3,
          where << ": 'world_mm' entry " << k << " must be [x, y, z], got " << w[k].dump());
      for (int c = 0; c < 3; ++c) {
        GIMM_CHECK_AS(
            FormatError, w[k][c].is_number() && std::isfinite(w[k][c].get<double>()),
            where << ": 'world_mm' entry " << k << " has a non-number " << w[k][c].dump());
        world[k][c] = w[k][c].get<double>();
      }
    }
  }
  for (std::size_t k = 0; k < a.size(); ++k) {
    GIMM_CHECK_AS(FormatError,
                  a[k].allFinite() && b[k].allFinite() && a[k].minCoeff() >= -0.5 &&
                      b[k].minCoeff() >= -0.5 && a[k].maxCoeff() < kMaxTruthPixel &&
                      b[k].maxCoeff() < kMaxTruthPixel,
                  where << ": point " << k << " (A " << a[k].transpose() << ", B "
                        << b[k].transpose()
                        << ") is not a pixel position on a detector (finite, -0.5 to "
                        << kMaxTruthPixel << " px)");
    Correspondence c;
    c.a = a[k];
    c.b = b[k];
    c.world = world[k];
    t.dense.push_back(c);
  }
  if (j.contains("F")) {
    t.F = matrix_from_json<3, 3>(j, "F", where);
    GIMM_CHECK_AS(FormatError, t.F.cwiseAbs().maxCoeff() > 0,
                  where << ": 'F' is all zeros (no epipolar geometry; leave it out instead)");
  }
  t.mask_a = sparse_truth_mask(a, radius_px);
  t.mask_b = sparse_truth_mask(b, radius_px);
  return t;
}

/// The rule pairing a truth with a matches file (gimm-eval --truth/--matches, in one order):
/// a matches file that names its pair (gimm-match --dataset writes "<patient>/<pair>"; one pair
/// matched alone names none) must name the truth's pair, its "pair" or else its file's stem,
/// whole or after a "<patient>/". Scoring one pair's matches against another's truth gives
/// figures that look like a bad matcher.
inline void check_same_pair(const PairTruth& truth, const std::string& truth_file,
                            const PairMatches& matches, const std::string& matches_file) {
  const std::string& named = matches.pair;
  const bool agrees =
      named.empty() || named == truth.id ||
      (named.size() > truth.id.size() &&
       named.compare(named.size() - truth.id.size(), truth.id.size(), truth.id) == 0 &&
       named[named.size() - truth.id.size() - 1] == '/');
  GIMM_CHECK(agrees, matches_file << " holds the matches of pair '" << named << "', but "
                                  << truth_file << " is the truth of pair '" << truth.id
                                  << "': give the files in the same order, or set the truth's "
                                     "\"pair\"");
}

}  // namespace gimm
