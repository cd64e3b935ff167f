#pragma once
/// The coronary tree's side branches beyond the named main ones, and calibres by Murray's law
/// (TreeDetail::rich): what a clinical angiogram shows and the classic phantom tree lacks.
///
/// Classic (the default, what the shipped weights were trained on): 10-12 branches, LM, LAD,
/// D1, D2, LCx, OM1, OM2, RCA, AM and, by dominance, PDA/PLB, each tapering linearly.
/// Rich adds, drawn from a stream of their own (the classic branches' points stay as they are):
///   LAD   3-5 septal perforators (S1..S5) running into the septum, a third diagonal (D3, 60%);
///   LM    a ramus intermedius (RI, 30%);
///   LCx   a third obtuse marginal (OM3, 50%, not with left dominance);
///   RCA   the conus branch (CB), the sinus node artery (SN, 60%), two right-ventricular
///         branches (RV1, RV2), a second acute marginal (AM2, 50%, not with left dominance);
///   PLB   a second posterolateral branch (PLB2, 60%, right dominance);
///   and a twig (D1t, OM2t, ...) off the middle of each of D1, D2, OM1, OM2, AM, RV1 and the
///   PDA (70% each).
/// 20-29 branches in all (25 on average). Calibres: the roots' proximal radii from Dodge et al.
/// (Circulation 1992;86:232-246: left main 4.5 +- 0.5 mm, proximal LAD 3.7 +- 0.4 mm, proximal
/// RCA 3.9 +- 0.6 mm with right and 2.8 +- 0.5 mm with left dominance, proximal LCx 3.4 +- 0.5
/// and 4.2 +- 0.6 mm), a side branch's from its class, and along every branch Murray's law (Murray
/// 1926: r^3 of a parent = the sum of its children's r^3) at each side branch's origin, with a 1.3%
/// per cm taper between them and a 0.5 mm floor. The distal LAD then comes out at 2.0 mm in
/// diameter on average over 64 seeds (sd 0.5 mm), Dodge's 1.9 +- 0.4 mm. docs/phantom.md.
#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "gimm/anatomy/centerlines.hpp"
#include "gimm/core/error.hpp"
#include "gimm/core/rng.hpp"

namespace gimm {

enum class TreeDetail { classic, rich };

inline TreeDetail parse_tree_detail(const std::string& s) {
  if (s == "classic") return TreeDetail::classic;
  if (s == "rich") return TreeDetail::rich;
  GIMM_FAIL("coronary tree must be classic|rich, got '" << s << "'");
}
inline const char* to_string(TreeDetail t) {
  return t == TreeDetail::rich ? "rich" : "classic";
}

/// The smallest lumen radius of a rich tree, mm.
constexpr double kMinBranchRadiusMm = 0.5;

namespace detail {

inline int branch_index(const CenterlineTree& tree, const std::string& name,
                        CoronarySystem system) {
  for (std::size_t b = 0; b < tree.branches.size(); ++b)
    if (tree.branches[b].name == name && tree.branches[b].system == system)
      return static_cast<int>(b);
  return -1;
}

/// The index of `parent`'s point nearest to p (where a side branch leaves it).
inline std::size_t origin_index(const CenterlineBranch& parent, const Eigen::Vector3d& p) {
  std::size_t best = 0;
  for (std::size_t n = 1; n < parent.points.size(); ++n)
    if ((parent.points[n] - p).squaredNorm() < (parent.points[best] - p).squaredNorm()) best = n;
  return best;
}

/// A septal perforator: from `start` into the myocardium, `length` mm along `inward` bending
/// towards `apex` (both unit vectors), sampled every `step` mm.
inline std::vector<Eigen::Vector3d> septal_path(const Eigen::Vector3d& start,
                                                const Eigen::Vector3d& inward,
                                                const Eigen::Vector3d& apex, double length,
                                                double bend, double step) {
  std::vector<Eigen::Vector3d> out{start};
  Eigen::Vector3d p = start;
  for (double s = step; s <= length + 1e-9; s += step) {
    const double t = s / length;
    const Eigen::Vector3d dir = ((1 - bend * t) * inward + (0.45 + bend * t) * apex).normalized();
    p += step * dir;
    out.push_back(p);
  }
  return out;
}

}  // namespace detail

/// The proximal radius (mm) of each branch of a rich tree, by name, drawn from `rng`.
inline double proximal_radius(const std::string& name, bool left_dominant, Rng& rng) {
  const auto jitter = [&](double spread) { return rng.uniform(-spread, spread); };
  if (name == "LM") return 2.25 + jitter(0.25);
  if (name == "LAD") return 1.85 + jitter(0.2);
  if (name == "LCx") return (left_dominant ? 2.1 : 1.7) + jitter(0.25);
  if (name == "RCA") return (left_dominant ? 1.4 : 1.95) + jitter(0.25);
  if (name == "D1" || name == "OM1" || name == "RI") return 1.15 + jitter(0.1);
  if (name == "D2" || name == "OM2" || name == "PDA" || name == "PLB" || name == "AM")
    return 0.95 + jitter(0.1);
  if (name == "S1" || name == "D3" || name == "OM3" || name == "RV1" || name == "RV2")
    return 0.8 + jitter(0.08);
  return 0.68 + jitter(0.08);  // S2.., conus, sinus node, AM2, PLB2
}

/// Radii along every branch: the proximal radius, less by Murray's law at each side branch's
/// origin, a 1.3% per cm taper, and the floor kMinBranchRadiusMm. `proximal[b]` for branch b; a
/// side branch is kept to 0.8 of its parent's radius where it leaves. Parents come before their
/// children in the tree (as make_phantom builds it).
inline void murray_radii(CenterlineTree& tree, std::vector<double> proximal) {
  GIMM_CHECK(
      proximal.size() == tree.branches.size(),
      "murray_radii: " << proximal.size() << " radii for " << tree.branches.size() << " branches");
  // Side branches leaving each branch: (the index where they leave it, the side branch).
  std::vector<std::vector<std::pair<std::size_t, std::size_t>>> leaving(tree.branches.size());
  for (std::size_t c = 0; c < tree.branches.size(); ++c) {
    const int p = tree.branches[c].parent;
    if (p < 0) continue;
    GIMM_CHECK(static_cast<std::size_t>(p) < c,
               "murray_radii: branch '" << tree.branches[c].name << "' comes before its parent");
    const auto& parent = tree.branches[static_cast<std::size_t>(p)];
    const std::size_t at = detail::origin_index(parent, tree.branches[c].points.front());
    // A continuation (LAD and LCx from the end of the LM) takes nothing from its parent.
    if (at + 1 < parent.points.size()) leaving[static_cast<std::size_t>(p)].push_back({at, c});
  }
  const double floor_cube = std::pow(kMinBranchRadiusMm, 3);
  for (std::size_t b = 0; b < tree.branches.size(); ++b) {
    CenterlineBranch& br = tree.branches[b];
    std::sort(leaving[b].begin(), leaving[b].end());
    // r^3 carried down the branch: the taper shrinks it step by step (as if by branches too
    // small to draw), a side branch takes its own r^3 where it leaves.
    double cube = std::pow(proximal[b], 3);
    std::size_t next = 0;
    for (std::size_t n = 0; n < br.points.size(); ++n) {
      if (n > 0)
        cube *= std::pow(std::max(0.0, 1.0 - 0.0013 * (br.points[n] - br.points[n - 1]).norm()), 3);
      for (; next < leaving[b].size() && leaving[b][next].first <= n; ++next) {
        double& side = proximal[leaving[b][next].second];
        side = std::max(kMinBranchRadiusMm, std::min(side, 0.8 * std::cbrt(cube)));
        cube -= std::pow(side, 3);
      }
      cube = std::max(cube, floor_cube);
      br.radii[n] = std::cbrt(cube);
    }
  }
}

/// Adds the rich tree's side branches to `tree` (a classic phantom tree) and sets every
/// branch's radii by murray_radii. `trace(parent, f, control)` is a surface path from the
/// parent's point at fraction f through (h mm, phi degrees) control points; `inward(p)` the unit
/// vector into the heart at p; `locate(p)` p's (h mm, phi degrees) on the heart; `apex` the unit
/// long axis; `H` the heart's height (mm).
template <class Trace, class Inward, class Locate>
void add_side_branches(CenterlineTree& tree, Trace trace, Inward inward, Locate locate,
                       const Eigen::Vector3d& apex, double H, bool left_dominant,
                       bool right_dominant, double step, Rng& rng) {
  using Control = std::vector<std::array<double, 2>>;
  const auto LCA = CoronarySystem::LCA, RCA = CoronarySystem::RCA;
  const auto jitter = [&](double spread) { return rng.uniform(-spread, spread); };
  const auto chance = [&](double p) { return rng.uniform() < p; };
  const auto add = [&](const std::string& name, CoronarySystem system, int parent,
                       std::vector<Eigen::Vector3d> points) {
    CenterlineBranch b;
    b.name = name;
    b.system = system;
    b.parent = parent;
    b.radii.assign(points.size(), 1.0);  // set by murray_radii below
    b.points = std::move(points);
    tree.branches.push_back(std::move(b));
  };
  const int lm = detail::branch_index(tree, "LM", LCA),
            lad = detail::branch_index(tree, "LAD", LCA);
  const int lcx = detail::branch_index(tree, "LCx", LCA),
            rca = detail::branch_index(tree, "RCA", RCA);
  GIMM_CHECK(lm >= 0 && lad >= 0 && lcx >= 0 && rca >= 0,
             "add_side_branches: the tree lacks LM, LAD, LCx or RCA");

  // Septal perforators: every 10-12% of the LAD's proximal half, into the septum and down.
  const int septals = 3 + static_cast<int>(rng.uniform() * 3);
  for (int s = 0; s < septals; ++s) {
    const auto& lad_points = tree.branches[static_cast<std::size_t>(lad)].points;
    const double f = 0.08 + 0.11 * s + jitter(0.025);
    const Eigen::Vector3d start =
        lad_points[static_cast<std::size_t>(f * static_cast<double>(lad_points.size() - 1))];
    const double length = (s == 0 ? 30 : 24 - 3 * s) + jitter(4);
    const double bend = rng.uniform(0.1, 0.4);
    add("S" + std::to_string(s + 1), LCA, lad,
        detail::septal_path(start, inward(start), apex, length, bend, step));
  }
  if (chance(0.6))
    add("D3", LCA, lad,
        trace(lad, 0.68 + jitter(0.05),
              Control{{0.85 * H, 42 + jitter(6)}, {0.97 * H, 48 + jitter(6)}}));
  if (chance(0.3))
    add("RI", LCA, lm,
        trace(lm, 1.0, Control{{0.35 * H, 62 + jitter(6)}, {0.7 * H, 78 + jitter(8)}}));
  if (!left_dominant && chance(0.5))  // short of the RCA's posterolateral branches (165 deg on)
    add("OM3", LCA, lcx,
        trace(lcx, 0.88 + jitter(0.04),
              Control{{0.45 * H, 150 + jitter(4)}, {0.62 * H, 152 + jitter(4)}}));

  // The first two leave where the RCA has reached its groove (before, it crosses from the
  // aortic root); the conus stays right of the LAD's groove.
  add("CB", RCA, rca,
      trace(rca, 0.15 + jitter(0.02), Control{{5, -30 + jitter(5)}, {12, -16 + jitter(4)}}));
  if (chance(0.6))
    add("SN", RCA, rca,
        trace(rca, 0.18 + jitter(0.02), Control{{-18, -70 + jitter(8)}, {-32, -80 + jitter(10)}}));
  add("RV1", RCA, rca,
      trace(rca, 0.28 + jitter(0.04),
            Control{{0.35 * H, -45 + jitter(6)}, {0.55 * H, -38 + jitter(6)}}));
  add("RV2", RCA, rca,
      trace(rca, 0.4 + jitter(0.04),
            Control{{0.4 * H, -62 + jitter(6)}, {0.6 * H, -58 + jitter(6)}}));
  if (!left_dominant && chance(0.5))
    add("AM2", RCA, rca,
        trace(rca, 0.7 + jitter(0.04),
              Control{{0.45 * H, -115 + jitter(6)}, {0.65 * H, -112 + jitter(6)}}));
  const int plb = detail::branch_index(tree, "PLB", RCA);
  if (right_dominant && plb >= 0 && chance(0.6))
    add("PLB2", RCA, plb, trace(plb, 0.5, Control{{0.35 * H, 182 + jitter(4)}}));

  // Twigs: a small branch off the middle of each diagonal, marginal, RV branch and PDA (70%
  // each), turning 10-18 degrees off its parent's course to either side, ending before it.
  for (const char* name : {"D1", "D2", "OM1", "OM2", "AM", "RV1", "PDA"})
    for (const CoronarySystem system : {LCA, RCA}) {
      const int parent = detail::branch_index(tree, name, system);
      if (parent < 0 || !chance(0.7)) continue;
      const double f = rng.uniform(0.35, 0.65);
      const auto& pp = tree.branches[static_cast<std::size_t>(parent)].points;
      const auto at = locate(pp[static_cast<std::size_t>(f * static_cast<double>(pp.size() - 1))]);
      const auto end = locate(pp.back());
      double dphi = end[1] - at[1];
      while (dphi > 180) dphi -= 360;
      while (dphi < -180) dphi += 360;
      const double side = chance(0.5) ? 1.0 : -1.0, turn = side * rng.uniform(10, 18);
      add(std::string(name) + "t", system, parent,
          trace(parent, f,
                Control{{at[0] + 0.35 * (end[0] - at[0]) + 3, at[1] + 0.35 * dphi + 0.6 * turn},
                        {at[0] + 0.7 * (end[0] - at[0]) + 5, at[1] + 0.7 * dphi + turn}}));
    }

  std::vector<double> proximal;
  for (const auto& b : tree.branches)
    proximal.push_back(proximal_radius(b.name, left_dominant, rng));
  murray_radii(tree, proximal);
}

}  // namespace gimm
