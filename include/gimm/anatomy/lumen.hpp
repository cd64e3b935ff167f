#pragma once
/// The lumen beyond a smooth taper: focal stenoses and the irregular calibre of real coronary
/// arteries (issue "synthetic angiograms that look like real ones": a real tree's lumen narrows
/// at plaques and is never a perfect taper). Both change the tree's radii only, before the
/// volume is sampled, so the DRR, the masks and the labels all see the same lumen.
///
/// Stenoses: `stenoses` of them, each on a distinct named epicardial branch (LM, LAD, LCx, RCA,
/// the diagonals, marginals, PDA/PLB, the ramus; not septals, twigs or the small right
/// branches), centred at a uniform place along its proximal 70% (at least 10 mm from both ends),
/// 4-12 mm long, reducing the diameter by 30-80% (uniform; angiographically mild to severe,
/// Gensini's and SYNTAX's grades run 25-99%) with a raised-cosine profile. A branch whose lumen
/// is under 1 mm of radius there is not chosen (a stenosis there would not be seen).
/// Irregularity: every radius times exp(sigma * g(s)), g a unit-variance Gaussian process along
/// the branch's arc length s (white noise smoothed over `irregularity_mm`), so the calibre wavers
/// by about sigma (0.05-0.1 look like angiograms; 0 = the smooth taper).
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "gimm/anatomy/centerlines.hpp"
#include "gimm/core/constants.hpp"
#include "gimm/core/error.hpp"
#include "gimm/core/rng.hpp"

namespace gimm {

struct LumenOptions {
  int stenoses = 0;            ///< focal stenoses per patient, [0, 8]
  double irregularity = 0;     ///< sigma of the log-radius wavering, [0, 0.3]; 0 = smooth
  double irregularity_mm = 4;  ///< its correlation length along the vessel, (0, 50] mm
  bool none() const { return stenoses == 0 && irregularity == 0; }
  void validate() const {
    GIMM_CHECK(stenoses >= 0 && stenoses <= 8,
               "LumenOptions::stenoses must be in [0, 8], got " << stenoses);
    GIMM_CHECK(std::isfinite(irregularity) && irregularity >= 0 && irregularity <= 0.3,
               "LumenOptions::irregularity must be in [0, 0.3], got " << irregularity);
    GIMM_CHECK(std::isfinite(irregularity_mm) && irregularity_mm > 0 && irregularity_mm <= 50,
               "LumenOptions::irregularity_mm must be in (0, 50] mm, got " << irregularity_mm);
  }
};

/// One stenosis as drawn: where, how long, how tight.
struct Stenosis {
  std::string branch;
  double at_mm = 0;      ///< its centre, arc length from the branch's start
  double length_mm = 0;  ///< the whole narrowing
  double severity = 0;   ///< diameter reduction at the centre, 0..1
};

namespace detail {

inline bool stenosable(const std::string& name) {
  for (const char* root : {"LM", "LAD", "LCx", "RCA", "RI", "PDA", "PLB"})
    if (name == root) return true;
  // D1-D3, OM1-OM3, AM (not the twigs "D1t", ...).
  return name.size() == 2 && (name[0] == 'D' && name[1] >= '1' && name[1] <= '3');
}

inline bool stenosable_marginal(const std::string& name) {
  return (name.size() == 3 && name.rfind("OM", 0) == 0 && name[2] >= '1' && name[2] <= '3') ||
         name == "AM";
}

inline std::vector<double> arc_lengths(const CenterlineBranch& b) {
  std::vector<double> s(b.points.size(), 0.0);
  for (std::size_t n = 1; n < s.size(); ++n)
    s[n] = s[n - 1] + (b.points[n] - b.points[n - 1]).norm();
  return s;
}

/// A unit-variance smooth process at arc lengths `s`: white noise on a 0.5 mm grid smoothed by
/// a Gaussian of sigma `correlation_mm`, rescaled to unit variance.
inline std::vector<double> smooth_process(const std::vector<double>& s, double correlation_mm,
                                          Rng& rng) {
  const double grid = 0.5;
  const int reach = static_cast<int>(std::ceil(3 * correlation_mm / grid));
  const int cells = static_cast<int>(std::ceil(s.back() / grid)) + 1;
  std::vector<double> white(cells + 2 * reach);
  for (double& w : white) w = rng.normal();
  std::vector<double> kernel(2 * reach + 1);
  double norm2 = 0;
  for (int j = -reach; j <= reach; ++j) {
    const double x = j * grid / correlation_mm;
    kernel[j + reach] = std::exp(-0.5 * x * x);
    norm2 += kernel[j + reach] * kernel[j + reach];
  }
  std::vector<double> out(s.size());
  for (std::size_t n = 0; n < s.size(); ++n) {
    const int centre = static_cast<int>(std::lround(s[n] / grid)) + reach;
    double v = 0;
    for (int j = -reach; j <= reach; ++j) v += kernel[j + reach] * white[centre + j];
    out[n] = v / std::sqrt(norm2);  // a sum of unit-variance terms: unit variance again
  }
  return out;
}

}  // namespace detail

/// The tree's radii shaped as `o` asks (see the header comment), drawn from `rng`; returns the
/// stenoses drawn (fewer than asked when the tree has too few branches wide enough).
inline std::vector<Stenosis> shape_lumen(CenterlineTree& tree, const LumenOptions& o, Rng& rng) {
  o.validate();
  std::vector<Stenosis> drawn;
  if (o.none()) return drawn;
  // Irregularity first, a stream per branch (by index) so a stenosis does not shift it.
  if (o.irregularity > 0)
    for (std::size_t b = 0; b < tree.branches.size(); ++b) {
      CenterlineBranch& br = tree.branches[b];
      if (br.points.size() < 2) continue;
      Rng branch_rng = rng.fork(0x1e11 + b);
      const std::vector<double> g =
          detail::smooth_process(detail::arc_lengths(br), o.irregularity_mm, branch_rng);
      for (std::size_t n = 0; n < br.radii.size(); ++n)
        br.radii[n] *= std::exp(o.irregularity * g[n]);
    }
  // Candidates: named branches long enough, wide enough where the stenosis would sit.
  std::vector<std::size_t> candidates;
  for (std::size_t b = 0; b < tree.branches.size(); ++b) {
    const CenterlineBranch& br = tree.branches[b];
    if ((detail::stenosable(br.name) || detail::stenosable_marginal(br.name)) &&
        br.length() >= 30 && br.radii.front() >= 1.0)
      candidates.push_back(b);
  }
  Rng pick = rng.fork(0x57e0);
  for (int k = 0; k < o.stenoses && !candidates.empty(); ++k) {
    const std::size_t slot = pick.below(candidates.size());
    CenterlineBranch& br = tree.branches[candidates[slot]];
    candidates.erase(candidates.begin() + static_cast<std::ptrdiff_t>(slot));
    const std::vector<double> s = detail::arc_lengths(br);
    Stenosis st;
    st.branch = br.name;
    st.length_mm = pick.uniform(4, 12);
    st.severity = pick.uniform(0.3, 0.8);
    st.at_mm = pick.uniform(10, std::max(10.0, std::min(0.7 * s.back(), s.back() - 10)));
    // Only where the lumen is 1 mm or wider: else the nearest point up the branch that is.
    std::size_t centre = std::lower_bound(s.begin(), s.end(), st.at_mm) - s.begin();
    while (centre > 0 && br.radii[std::min(centre, br.radii.size() - 1)] < 1.0) --centre;
    centre = std::min(centre, s.size() - 1);
    st.at_mm = s[centre];
    const double half = 0.5 * st.length_mm;
    for (std::size_t n = 0; n < s.size(); ++n) {
      const double d = std::abs(s[n] - st.at_mm);
      if (d < half) br.radii[n] *= 1 - st.severity * 0.5 * (1 + std::cos(kPi * d / half));
    }
    drawn.push_back(st);
  }
  return drawn;
}

}  // namespace gimm
