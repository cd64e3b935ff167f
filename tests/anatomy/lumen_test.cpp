// The lumen beyond a smooth taper (anatomy/lumen.hpp): stenoses narrow the radius by their
// severity at their centre and nowhere beyond their length; the irregular calibre wavers by
// the sigma asked, smoothly; nothing asked, nothing changed; the phantom's label follows.
#include <catch2/catch.hpp>
#include <cmath>

#include "gimm/anatomy/lumen.hpp"
#include "gimm/anatomy/phantom.hpp"

using namespace gimm;

namespace {

/// A straight branch of `n` points 0.5 mm apart with radius r0 everywhere.
CenterlineTree straight(const std::string& name, int n, double r0) {
  CenterlineTree t;
  CenterlineBranch b;
  b.name = name;
  for (int k = 0; k < n; ++k) {
    b.points.emplace_back(0.5 * k, 0, 0);
    b.radii.push_back(r0);
  }
  t.branches.push_back(b);
  return t;
}

Phantom rich_phantom(std::uint64_t seed, LumenOptions lumen) {
  PhantomOptions o;
  o.seed = seed;
  o.noise_hu = 0;
  o.tree = TreeDetail::rich;
  o.lumen = lumen;
  return make_phantom(o);
}

}  // namespace

TEST_CASE("Lumen: a stenosis narrows by its severity at its centre and only along its length",
          "[anatomy][lumen]") {
  CenterlineTree t = straight("LAD", 201, 2.0);  // 100 mm
  LumenOptions o;
  o.stenoses = 1;
  Rng rng(3);
  const std::vector<Stenosis> s = shape_lumen(t, o, rng);
  REQUIRE(s.size() == 1);
  CHECK(s[0].branch == "LAD");
  CHECK(s[0].severity >= 0.3);
  CHECK(s[0].severity <= 0.8);
  CHECK(s[0].length_mm >= 4);
  CHECK(s[0].length_mm <= 12);
  CHECK(s[0].at_mm >= 10);
  CHECK(s[0].at_mm <= 70);
  const auto& radii = t.branches[0].radii;
  const std::size_t centre = static_cast<std::size_t>(std::lround(s[0].at_mm / 0.5));
  CHECK(radii[centre] == Approx(2.0 * (1 - s[0].severity)));  // the raised cosine's floor
  for (std::size_t k = 0; k < radii.size(); ++k) {
    const double d = std::abs(0.5 * k - s[0].at_mm);
    if (d >= 0.5 * s[0].length_mm)
      CHECK(radii[k] == 2.0);
    else
      CHECK(radii[k] < 2.0);
  }
}

TEST_CASE("Lumen: stenoses only where they would be seen, one per branch", "[anatomy][lumen]") {
  CenterlineTree t = straight("S1", 201, 2.0);                  // a septal: not a place for one
  t.branches.push_back(straight("RCA", 201, 0.7).branches[0]);  // too narrow
  t.branches.push_back(straight("D1", 201, 1.5).branches[0]);
  LumenOptions o;
  o.stenoses = 3;
  Rng rng(5);
  const std::vector<Stenosis> s = shape_lumen(t, o, rng);
  REQUIRE(s.size() == 1);  // fewer than asked: D1 is the only candidate
  CHECK(s[0].branch == "D1");
  for (double r : t.branches[0].radii) CHECK(r == 2.0);
  for (double r : t.branches[1].radii) CHECK(r == 0.7);
}

TEST_CASE("Lumen: the irregular calibre wavers by the sigma asked, smoothly", "[anatomy][lumen]") {
  CenterlineTree t = straight("LAD", 20001, 2.0);  // 10 m: enough for the statistics
  LumenOptions o;
  o.irregularity = 0.08;
  o.irregularity_mm = 4;
  Rng rng(9);
  CHECK(shape_lumen(t, o, rng).empty());
  const auto& r = t.branches[0].radii;
  double sum = 0, sum2 = 0, lag = 0;
  std::vector<double> g(r.size());
  for (std::size_t k = 0; k < r.size(); ++k) g[k] = std::log(r[k] / 2.0);
  for (std::size_t k = 0; k < g.size(); ++k) {
    sum += g[k];
    sum2 += g[k] * g[k];
    if (k > 0) lag += g[k] * g[k - 1];
  }
  const double n = static_cast<double>(g.size()), mean = sum / n, sd = std::sqrt(sum2 / n);
  CHECK(std::abs(mean) < 0.01);
  CHECK(sd == Approx(0.08).epsilon(0.15));
  // Neighbours 0.5 mm apart, correlation length 4 mm: exp(-0.5^2 / (4 * 4^2)) = 0.996.
  CHECK(lag / sum2 > 0.98);
}

TEST_CASE("Lumen: nothing asked, nothing drawn; bad options named", "[anatomy][lumen]") {
  CenterlineTree t = straight("LAD", 101, 2.0);
  Rng rng(1);
  CHECK(shape_lumen(t, {}, rng).empty());
  for (double r : t.branches[0].radii) CHECK(r == 2.0);
  LumenOptions bad;
  bad.stenoses = 9;
  CHECK_THROWS_WITH(shape_lumen(t, bad, rng), Catch::Contains("stenoses must be in [0, 8], got 9"));
  bad = {};
  bad.irregularity = std::nan("");
  CHECK_THROWS_WITH(bad.validate(), Catch::Contains("irregularity must be in [0, 0.3], got nan"));
  bad = {};
  bad.irregularity_mm = 0;
  CHECK_THROWS_WITH(bad.validate(), Catch::Contains("irregularity_mm must be in (0, 50]"));
}

TEST_CASE("Lumen: the phantom's label narrows with its stenoses, nothing else moves",
          "[anatomy][lumen]") {
  LumenOptions two;
  two.stenoses = 2;
  const Phantom plain = rich_phantom(12, {}), narrowed = rich_phantom(12, two);
  REQUIRE(narrowed.anatomy.stenoses.size() == 2);
  CHECK(plain.anatomy.stenoses.empty());
  // The course of every branch is the same; only radii near the stenoses differ.
  REQUIRE(plain.centerlines.branches.size() == narrowed.centerlines.branches.size());
  for (std::size_t b = 0; b < plain.centerlines.branches.size(); ++b)
    CHECK(plain.centerlines.branches[b].points == narrowed.centerlines.branches[b].points);
  std::size_t plain_voxels = 0, narrowed_voxels = 0;
  for (auto v : plain.label.storage()) plain_voxels += v != 0;
  for (auto v : narrowed.label.storage()) narrowed_voxels += v != 0;
  CHECK(narrowed_voxels < plain_voxels);
  CHECK(narrowed_voxels > 0.9 * plain_voxels);
}
