#pragma once
/// Dataset figures from per-pair scores (protocol.hpp): pooled, by system, by view-class pair,
/// per pair, and as a function of K; JSON and Markdown renderings.
///
/// Definitions (K = the number of most confident matches kept per pair; K = 0 means all):
///   kept      = min(K, matches) per pair (all matches for K = 0);
///   slots     = 2 K per pair (2 matches for K = 0): both directions of every match asked for;
///   scored    = direction-matches whose source is on the source mask (protocol.hpp);
///   coverage  = scored / slots, so a method that gives fewer than K matches, or matches off
///               the vessel, is penalised here (and only here);
///   Prec@N px = fraction of scored errors <= N px; mean / median / p90 of the 2D (px) and 3D
///               (mm) errors over all scored direction-matches of all pairs (pooled, not a mean
///               of per-pair means); percentiles interpolate linearly between order
///               statistics (numpy's default);
///   epipolar  = the symmetric epipolar distance under the true F of every kept match (one per
///               match, mask or not): mean, median, and the fraction <= epipolar_px_ok (2 px).
/// Undefined figures (nothing scored, no slots) are NaN, written as JSON null and "-" in tables.
/// Because everything is pooled from counts and error lists, the per-system (and per class
/// pair) counts add up to the pooled counts and their scored-weighted means to the pooled means.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/io/files.hpp"
#include "gimm/metrics/protocol.hpp"

namespace gimm {

constexpr double kPrecisionThresholds[3] = {1.0, 3.0, 5.0};
constexpr double kEpipolarOkPx = 2.0;

/// Linear-interpolation percentile (q in [0, 1]) of unsorted values; NaN if empty.
inline double percentile(std::vector<double> values, double q) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(values.begin(), values.end());
  const double pos = q * static_cast<double>(values.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(pos));
  const std::size_t hi = std::min(lo + 1, values.size() - 1);
  return values[lo] + (pos - static_cast<double>(lo)) * (values[hi] - values[lo]);
}

inline double mean_of(const std::vector<double>& values) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  double s = 0;
  for (double v : values) s += v;
  return s / static_cast<double>(values.size());
}

struct Summary {
  std::size_t pairs = 0, missing = 0;  ///< pairs, and those without a predictions file
  std::size_t matches = 0, kept = 0, slots = 0, scored = 0;
  double coverage = std::numeric_limits<double>::quiet_NaN();
  double prec[3] = {std::numeric_limits<double>::quiet_NaN(),
                    std::numeric_limits<double>::quiet_NaN(),
                    std::numeric_limits<double>::quiet_NaN()};  ///< @ kPrecisionThresholds
  double mean_px = std::numeric_limits<double>::quiet_NaN();
  double median_px = std::numeric_limits<double>::quiet_NaN();
  double p90_px = std::numeric_limits<double>::quiet_NaN();
  double mean_mm = std::numeric_limits<double>::quiet_NaN();
  double median_mm = std::numeric_limits<double>::quiet_NaN();
  double p90_mm = std::numeric_limits<double>::quiet_NaN();
  std::size_t epipolar_count = 0;
  double epipolar_mean_px = std::numeric_limits<double>::quiet_NaN();
  double epipolar_median_px = std::numeric_limits<double>::quiet_NaN();
  double epipolar_ok = std::numeric_limits<double>::quiet_NaN();  ///< fraction <= 2 px
};

/// Collects the kept matches of pairs, then summarises them.
class SummaryBuilder {
 public:
  explicit SummaryBuilder(long k) : k_(k) {}

  /// Adds the first K ranked matches of `p` (p.ranked must hold at least that many, or all).
  void add(const PairScore& p) {
    ++s_.pairs;
    if (!p.has_predictions) ++s_.missing;
    s_.matches += p.matches;
    const std::size_t kept =
        k_ > 0 ? std::min<std::size_t>(static_cast<std::size_t>(k_), p.matches) : p.matches;
    GIMM_CHECK(p.ranked.size() >= kept,
               "SummaryBuilder: pair " << p.id << " has " << p.ranked.size() << " ranked matches, "
                                       << kept << " needed for K = " << k_);
    s_.kept += kept;
    s_.slots += 2 * (k_ > 0 ? static_cast<std::size_t>(k_) : p.matches);
    for (std::size_t r = 0; r < kept; ++r) {
      const RankedMatch& m = p.ranked[r];
      for (const DirectionScore* d : {&m.ab, &m.ba})
        if (d->scored) {
          px_.push_back(d->error_px);
          if (!std::isnan(d->error_mm)) mm_.push_back(d->error_mm);  // NaN: truth without 3D
        }
      if (!std::isnan(m.epipolar_px)) epi_.push_back(m.epipolar_px);
    }
  }

  Summary summary() const {
    Summary s = s_;
    s.scored = px_.size();
    if (s.slots > 0) s.coverage = static_cast<double>(s.scored) / static_cast<double>(s.slots);
    if (!px_.empty())
      for (int t = 0; t < 3; ++t)
        s.prec[t] =
            static_cast<double>(std::count_if(
                px_.begin(), px_.end(), [&](double e) { return e <= kPrecisionThresholds[t]; })) /
            static_cast<double>(px_.size());
    s.mean_px = mean_of(px_);
    s.median_px = percentile(px_, 0.5);
    s.p90_px = percentile(px_, 0.9);
    s.mean_mm = mean_of(mm_);
    s.median_mm = percentile(mm_, 0.5);
    s.p90_mm = percentile(mm_, 0.9);
    s.epipolar_count = epi_.size();
    s.epipolar_mean_px = mean_of(epi_);
    s.epipolar_median_px = percentile(epi_, 0.5);
    if (!epi_.empty())
      s.epipolar_ok = static_cast<double>(std::count_if(
                          epi_.begin(), epi_.end(), [](double e) { return e <= kEpipolarOkPx; })) /
                      static_cast<double>(epi_.size());
    return s;
  }

 private:
  long k_;
  Summary s_;
  std::vector<double> px_, mm_, epi_;
};

inline Summary summarize(const std::vector<PairScore>& pairs, long k) {
  SummaryBuilder b(k);
  for (const auto& p : pairs) b.add(p);
  return b.summary();
}

/// Summaries grouped by a key of each pair (e.g. system or class pair), in key order.
template <class KeyOf>
std::map<std::string, Summary> summarize_by(const std::vector<PairScore>& pairs, long k,
                                            KeyOf key_of) {
  std::map<std::string, SummaryBuilder> builders;
  for (const auto& p : pairs) builders.try_emplace(key_of(p), k).first->second.add(p);
  std::map<std::string, Summary> out;
  for (const auto& [key, b] : builders) out[key] = b.summary();
  return out;
}

/// The K values of a top-K curve: 5, 10, 20, 50, 100, 200, 500, ... below the largest match
/// count of any pair, the requested K, and 0 (= all) last.
inline std::vector<long> curve_ks(const std::vector<PairScore>& pairs, long requested_k) {
  std::size_t most = 0;
  for (const auto& p : pairs) most = std::max(most, p.matches);
  std::vector<long> ks;
  for (long decade = 1; static_cast<std::size_t>(5 * decade) < most; decade *= 10)
    for (long k : {5 * decade, 10 * decade, 20 * decade})
      if (static_cast<std::size_t>(k) < most) ks.push_back(k);
  if (requested_k > 0) ks.push_back(requested_k);
  std::sort(ks.begin(), ks.end());
  ks.erase(std::unique(ks.begin(), ks.end()), ks.end());
  ks.push_back(0);
  return ks;
}

// ---- JSON and Markdown ------------------------------------------------------------------

namespace detail {
inline nlohmann::json num(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nullptr;
}
inline double num_from(const nlohmann::json& j, const char* key) {
  return j.contains(key) && j.at(key).is_number() ? j.at(key).get<double>()
                                                  : std::numeric_limits<double>::quiet_NaN();
}
}  // namespace detail

inline nlohmann::json to_json(const Summary& s) {
  using detail::num;
  return {{"pairs", s.pairs},
          {"missing_pairs", s.missing},
          {"matches", s.matches},
          {"kept", s.kept},
          {"slots", s.slots},
          {"scored", s.scored},
          {"coverage", num(s.coverage)},
          {"prec_1px", num(s.prec[0])},
          {"prec_3px", num(s.prec[1])},
          {"prec_5px", num(s.prec[2])},
          {"mean_px", num(s.mean_px)},
          {"median_px", num(s.median_px)},
          {"p90_px", num(s.p90_px)},
          {"mean_mm", num(s.mean_mm)},
          {"median_mm", num(s.median_mm)},
          {"p90_mm", num(s.p90_mm)},
          {"epipolar_count", s.epipolar_count},
          {"epipolar_mean_px", num(s.epipolar_mean_px)},
          {"epipolar_median_px", num(s.epipolar_median_px)},
          {"epipolar_within_2px", num(s.epipolar_ok)}};
}

inline Summary summary_from_json(const nlohmann::json& j) {
  using detail::num_from;
  Summary s;
  s.pairs = j.value("pairs", std::size_t{0});
  s.missing = j.value("missing_pairs", std::size_t{0});
  s.matches = j.value("matches", std::size_t{0});
  s.kept = j.value("kept", std::size_t{0});
  s.slots = j.value("slots", std::size_t{0});
  s.scored = j.value("scored", std::size_t{0});
  s.coverage = num_from(j, "coverage");
  s.prec[0] = num_from(j, "prec_1px");
  s.prec[1] = num_from(j, "prec_3px");
  s.prec[2] = num_from(j, "prec_5px");
  s.mean_px = num_from(j, "mean_px");
  s.median_px = num_from(j, "median_px");
  s.p90_px = num_from(j, "p90_px");
  s.mean_mm = num_from(j, "mean_mm");
  s.median_mm = num_from(j, "median_mm");
  s.p90_mm = num_from(j, "p90_mm");
  s.epipolar_count = j.value("epipolar_count", std::size_t{0});
  s.epipolar_mean_px = num_from(j, "epipolar_mean_px");
  s.epipolar_median_px = num_from(j, "epipolar_median_px");
  s.epipolar_ok = num_from(j, "epipolar_within_2px");
  return s;
}

/// "0.547", or "-" when undefined.
inline std::string fmt(double v, int decimals = 3) {
  if (!std::isfinite(v)) return "-";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

/// The header of the results table (Table 1 of the paper plus coverage, median, p90, the
/// exact-geometry check and the counts).
inline std::string markdown_header(const std::string& first_column = "method") {
  return "| " + first_column +
         " | Prec@1px | Prec@3px | Prec@5px | 2D mean (px) | 2D median | 2D p90 | 3D mean (mm) "
         "| 3D median | 3D p90 | coverage | epipolar mean (px) | epipolar <= 2px | pairs | "
         "scored |\n"
         "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | "
         "--- |\n";
}

inline std::string markdown_row(const std::string& name, const Summary& s) {
  return "| " + name + " | " + fmt(s.prec[0]) + " | " + fmt(s.prec[1]) + " | " + fmt(s.prec[2]) +
         " | " + fmt(s.mean_px) + " | " + fmt(s.median_px) + " | " + fmt(s.p90_px) + " | " +
         fmt(s.mean_mm) + " | " + fmt(s.median_mm) + " | " + fmt(s.p90_mm) + " | " +
         fmt(s.coverage) + " | " + fmt(s.epipolar_mean_px) + " | " + fmt(s.epipolar_ok) + " | " +
         std::to_string(s.pairs) + " | " + std::to_string(s.scored) + " |\n";
}

}  // namespace gimm
