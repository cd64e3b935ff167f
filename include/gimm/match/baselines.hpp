#pragma once
/// Training-free matchers that calibrate the evaluation (docs/evaluation.md).
///
/// oracle:   every dense GT label a <-> b + n, n ~ N(0, sigma^2 I) in pixels (gimm::Rng), with a
///           uniform random confidence (so the top K is a random sample of the labels). With
///           sigma = 0 it is the labels themselves.
/// epipolar: for up to `max_points` vessel pixels of A (a seeded random sample of view A's mask,
///           in random order), the vessel pixels of B within `band_px` of the exact epipolar
///           line F a are grouped into crossings (runs along the line with gaps <= gap_px); each
///           crossing's point is the foot on the line of the middle of its run; the match is the
///           crossing nearest to a in pixels (the views share the isocentre, so the nearest is a
///           weak prior), with confidence 1 / (number of crossings). A pixels whose line meets
///           no vessel in B give no match.
#include <Eigen/Core>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/core/hash.hpp"
#include "gimm/core/rng.hpp"
#include "gimm/dataset/reader.hpp"
#include "gimm/match/matches.hpp"
#include "gimm/match/pair_matcher.hpp"

namespace gimm {

inline PairMatches oracle_matches(const PairTruth& truth, double sigma_px, Rng& rng) {
  GIMM_CHECK(std::isfinite(sigma_px) && sigma_px >= 0,
             "oracle: sigma_px must be finite and >= 0, got " << sigma_px);
  PairMatches m;
  m.pair = truth.id;
  for (const auto& c : truth.dense) {
    const double du = rng.normal(0, sigma_px), dv = rng.normal(0, sigma_px);
    m.add(c.a, c.b + Eigen::Vector2d(du, dv), rng.uniform());
  }
  return m;
}

struct EpipolarBaselineOptions {
  std::size_t max_points = 300;  ///< A pixels sampled, > 0
  double band_px = 1.0;          ///< B pixels within this distance of the line are candidates
  double gap_px = 2.0;           ///< a larger gap along the line starts a new crossing
  void validate() const {
    GIMM_CHECK(max_points > 0, "epipolar baseline: max_points must be > 0");
    GIMM_CHECK(std::isfinite(band_px) && band_px >= 0 && std::isfinite(gap_px) && gap_px >= 0,
               "epipolar baseline: band_px and gap_px must be finite and >= 0, got "
                   << band_px << " and " << gap_px);
  }
};

/// The vessel pixels of a mask as (u, v) = (column, row), row-major.
inline std::vector<Eigen::Vector2d> mask_pixels(const Image<std::uint8_t>& mask) {
  std::vector<Eigen::Vector2d> out;
  for (int r = 0; r < mask.rows(); ++r)
    for (int c = 0; c < mask.cols(); ++c)
      if (mask(r, c) != 0) out.emplace_back(c, r);
  return out;
}

/// The crossings of the line l = (a, b, c) with a set of pixels: the foot points on the line of
/// the middles of the runs of pixels within band_px of it, in order along the line.
inline std::vector<Eigen::Vector2d> line_crossings(const Eigen::Vector3d& l,
                                                   const std::vector<Eigen::Vector2d>& pixels,
                                                   double band_px, double gap_px) {
  std::vector<Eigen::Vector2d> out;
  const double n = std::hypot(l.x(), l.y());
  if (!(n > 0) || !l.allFinite()) return out;
  const Eigen::Vector2d normal = l.head<2>() / n;
  const Eigen::Vector2d dir(-normal.y(), normal.x());
  const Eigen::Vector2d foot0 = -l.z() / n * normal;  // the line's point nearest the origin
  std::vector<double> ts;
  for (const auto& q : pixels)
    if (std::abs(normal.dot(q) + l.z() / n) <= band_px) ts.push_back(dir.dot(q));
  std::sort(ts.begin(), ts.end());
  for (std::size_t s = 0; s < ts.size();) {
    std::size_t e = s;
    while (e + 1 < ts.size() && ts[e + 1] - ts[e] <= gap_px) ++e;
    out.push_back(foot0 + 0.5 * (ts[s] + ts[e]) * dir);
    s = e + 1;
  }
  return out;
}

inline PairMatches epipolar_matches(const PairTruth& truth, const EpipolarBaselineOptions& o,
                                    Rng& rng) {
  GIMM_CHECK(truth.mask_a && truth.mask_b,
             "epipolar baseline: pair " << truth.id << " has no masks");
  o.validate();
  PairMatches m;
  m.pair = truth.id;
  std::vector<Eigen::Vector2d> a_pixels = mask_pixels(*truth.mask_a);
  const std::vector<Eigen::Vector2d> b_pixels = mask_pixels(*truth.mask_b);
  // Partial Fisher-Yates: a seeded sample of max_points A pixels, in random order.
  const std::size_t count = std::min(o.max_points, a_pixels.size());
  for (std::size_t i = 0; i < count; ++i)
    std::swap(a_pixels[i], a_pixels[i + rng.below(a_pixels.size() - i)]);
  a_pixels.resize(count);
  for (const auto& a : a_pixels) {
    const auto crossings = line_crossings(truth.F * a.homogeneous(), b_pixels, o.band_px, o.gap_px);
    if (crossings.empty()) continue;
    std::size_t best = 0;
    for (std::size_t c = 1; c < crossings.size(); ++c)
      if ((crossings[c] - a).squaredNorm() < (crossings[best] - a).squaredNorm()) best = c;
    m.add(a, crossings[best], 1.0 / static_cast<double>(crossings.size()));
  }
  return m;
}

/// The per-pair random stream of a baseline: seeded by the run seed, the method and the pair,
/// so that a pair's matches do not depend on which other pairs are matched.
inline Rng baseline_stream(std::uint64_t seed, const std::string& method, const std::string& id) {
  return Rng(seed).fork(stable_hash(method + ":" + id));
}

namespace detail {
/// A baseline's matches as a matcher's result: all it proposes is kept.
template <class Make>
PairMatchResult baseline_result(Make make) {
  const auto start = std::chrono::steady_clock::now();
  PairMatchResult r;
  r.matches = make();
  r.candidates = static_cast<int>(r.matches.size());
  r.seconds = seconds_since(start);
  return r;
}
}  // namespace detail

/// The oracle behind the matcher interface (dataset mode: it reads the pair's labels).
class OracleMatcher : public PairMatcher {
 public:
  OracleMatcher(double sigma_px, std::uint64_t seed) : sigma_(sigma_px), seed_(seed) {
    GIMM_CHECK(std::isfinite(sigma_px) && sigma_px >= 0,
               "oracle: sigma_px must be finite and >= 0, got " << sigma_px);
  }
  std::string name() const override { return "oracle"; }
  bool needs_images() const override { return false; }

 protected:
  PairMatchResult run_method(const PairInput& pair) const override {
    GIMM_CHECK(pair.truth, "oracle: pair '" << pair.id << "' has no labels (dataset mode only)");
    Rng rng = baseline_stream(seed_, name(), pair.id);
    return detail::baseline_result([&] { return oracle_matches(*pair.truth, sigma_, rng); });
  }

 private:
  double sigma_;
  std::uint64_t seed_;
};

/// Epipolar-nearest behind the matcher interface: both vessel masks and the exact F of the pair.
class EpipolarMatcher : public PairMatcher {
 public:
  EpipolarMatcher(EpipolarBaselineOptions options, std::uint64_t seed)
      : options_(options), seed_(seed) {
    options_.validate();
  }
  std::string name() const override { return "epipolar"; }
  bool needs_images() const override { return false; }

 protected:
  PairMatchResult run_method(const PairInput& pair) const override {
    GIMM_CHECK(pair.truth,
               "epipolar: pair '" << pair.id << "' has no masks and F (dataset mode only)");
    Rng rng = baseline_stream(seed_, name(), pair.id);
    return detail::baseline_result([&] { return epipolar_matches(*pair.truth, options_, rng); });
  }

 private:
  EpipolarBaselineOptions options_;
  std::uint64_t seed_;
};

/// The baseline named `method` ("oracle": sigma_px; "epipolar": `epipolar`) behind the matcher
/// interface, with its per-pair random streams seeded by `seed`.
inline std::unique_ptr<PairMatcher> baseline_matcher(const std::string& method, double sigma_px,
                                                     const EpipolarBaselineOptions& epipolar,
                                                     std::uint64_t seed) {
  if (method == "oracle") return std::make_unique<OracleMatcher>(sigma_px, seed);
  GIMM_CHECK(method == "epipolar", "a baseline is 'oracle' or 'epipolar', got '" << method << "'");
  return std::make_unique<EpipolarMatcher>(epipolar, seed);
}

}  // namespace gimm
