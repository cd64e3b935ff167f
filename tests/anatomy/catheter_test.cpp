// The guiding catheter (anatomy/catheter.hpp): engaged in the injected system's ostium, inside
// the aorta all the way down, smooth enough to image as a tube, seeded, and named errors.
#include <catch2/catch.hpp>
#include <cmath>

#include "gimm/anatomy/catheter.hpp"

using namespace gimm;

namespace {

double distance_to_polyline(const Eigen::Vector3d& p, const std::vector<Eigen::Vector3d>& line,
                            std::size_t* segment = nullptr) {
  double best = 1e30;
  for (std::size_t i = 1; i < line.size(); ++i) {
    const Eigen::Vector3d ab = line[i] - line[i - 1];
    const double t = std::clamp((p - line[i - 1]).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
    const double d = (p - (line[i - 1] + t * ab)).norm();
    if (d < best) best = d, segment ? * segment = i - 1 : 0;
  }
  return best;
}

const CenterlineBranch& root_of(const Phantom& p, CoronarySystem system) {
  for (const auto& b : p.centerlines.branches)
    if (b.system == system && b.parent < 0) return b;
  FAIL("no root branch");
  return p.centerlines.branches.front();
}

}  // namespace

TEST_CASE("Catheter: engaged in the ostium, inside the aorta down to its end",
          "[anatomy][catheter]") {
  for (const std::uint64_t seed : {3u, 8u}) {
    PhantomOptions po;
    po.seed = seed;
    po.size = PhantomSize::chest;
    const Phantom p = make_phantom(po);
    for (const CoronarySystem system : {CoronarySystem::LCA, CoronarySystem::RCA}) {
      INFO("seed " << seed << ", " << to_string(system));
      Rng rng(seed);
      const CenterlineBranch c = guiding_catheter(p.anatomy, p.centerlines, system, rng);
      CHECK(c.name == "catheter");
      CHECK(c.system == system);
      CHECK_NOTHROW(CenterlineTree{{c}}.validate("catheter"));
      // The tip is inside the system's first branch, about engaged_mm in.
      const CenterlineBranch& root = root_of(p, system);
      CHECK(distance_to_polyline(c.points.front(), root.points) < 0.5 * root.radii.front());
      CHECK((c.points.front() - root.points.front()).norm() == Approx(4).margin(1.0));
      // Beyond the first 25 mm (the tip and the primary curve into the aorta) every point is
      // inside the aorta, within 0.8 of its radius of the axis; the end is the path's end.
      double along = 0;
      int outside = 0, checked = 0;
      for (std::size_t i = 1; i < c.points.size(); ++i) {
        along += (c.points[i] - c.points[i - 1]).norm();
        if (along < 25) continue;
        std::size_t seg = 0;
        const double d = distance_to_polyline(c.points[i], p.anatomy.aorta_path, &seg);
        ++checked;
        outside += d > 0.8 * p.anatomy.aorta_radius_mm[seg + 1];
      }
      CHECK(checked > 200);
      CHECK(outside == 0);
      CHECK((c.points.back() - p.anatomy.aorta_path.back()).norm() < 0.7 * 11.5);
      // Smooth: no bend tighter than 10 mm beyond the tip (a stiff tube over the arch).
      double tightest = 1e9;
      along = 0;
      for (std::size_t i = 1; i + 1 < c.points.size(); ++i) {
        along += (c.points[i] - c.points[i - 1]).norm();
        if (along < 25) continue;
        const Eigen::Vector3d a = c.points[i] - c.points[i - 1], b = c.points[i + 1] - c.points[i];
        const double turn = std::acos(std::clamp(a.dot(b) / (a.norm() * b.norm()), -1.0, 1.0));
        if (turn > 1e-9) tightest = std::min(tightest, 0.5 * (a.norm() + b.norm()) / turn);
      }
      CHECK(tightest > 10);
      // The same stream, the same catheter.
      Rng again(seed);
      CHECK(guiding_catheter(p.anatomy, p.centerlines, system, again).points == c.points);
    }
  }
}

TEST_CASE("Catheter: bad input is named", "[anatomy][catheter]") {
  PhantomOptions po;
  po.seed = 1;
  const Phantom p = make_phantom(po);
  Rng rng(1);
  PhantomAnatomy no_aorta = p.anatomy;
  no_aorta.aorta_path.clear();
  CHECK_THROWS_WITH(guiding_catheter(no_aorta, p.centerlines, CoronarySystem::LCA, rng),
                    Catch::Contains("no aorta path"));
  CenterlineTree lca_only;
  for (const auto& b : p.centerlines.branches)
    if (b.system == CoronarySystem::LCA) lca_only.branches.push_back(b);
  CHECK_THROWS_WITH(guiding_catheter(p.anatomy, lca_only, CoronarySystem::RCA, rng),
                    Catch::Contains("no RCA root branch"));
  CatheterOptions bad;
  bad.wall_offset_max = 0.95;
  CHECK_THROWS_WITH(guiding_catheter(p.anatomy, p.centerlines, CoronarySystem::LCA, rng, bad),
                    Catch::Contains("wall offset must lie in [0, 0.8], got [0.3, 0.95]"));
}
