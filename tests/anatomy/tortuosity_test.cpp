// The phantom's irregular course (anatomy/tortuosity.hpp): the main branches wander sideways by
// the sigma asked, from where they start; the tree stays one piece and labelled; nothing asked,
// nothing drawn; bad options are named.
#include <catch2/catch.hpp>
#include <cmath>

#include "gimm/anatomy/phantom.hpp"

using namespace gimm;

namespace {

Phantom phantom(std::uint64_t seed, TortuosityOptions tortuosity) {
  PhantomOptions o;
  o.seed = seed;
  o.noise_hu = 0;
  o.tortuosity = tortuosity;
  return make_phantom(o);
}

const CenterlineBranch& branch(const Phantom& p, const std::string& name) {
  for (const auto& b : p.centerlines.branches)
    if (b.name == name) return b;
  FAIL("no branch " << name);
  return p.centerlines.branches.front();
}

}  // namespace

TEST_CASE("Tortuosity: the main branches wander by sigma from where they start",
          "[anatomy][tortuosity]") {
  // LAD and LCx continue the straight left main, the RCA leaves its straight first part in the
  // AV groove: their control points are those of the classic course, so point n of each course
  // is the same sample of the same path, moved sideways by the wander instead of the classic
  // sinusoids (amplitudes U(0.6, 1.8) and U(0.3, 1.0) mm: mean square 1.01 mm^2). So the two
  // courses differ by sqrt(sigma^2 + 1.01) in RMS: 1.05 sigma at 3 mm.
  TortuosityOptions t;
  t.sigma_mm = 3.0;
  double sum_sq = 0, count = 0;
  for (std::uint64_t seed = 0; seed < 8; ++seed) {
    const Phantom classic = phantom(seed, {}), tortuous = phantom(seed, t);
    for (const char* name : {"LAD", "LCx", "RCA"}) {
      const auto& a = branch(classic, name);
      const auto& b = branch(tortuous, name);
      REQUIRE(a.points.size() == b.points.size());
      CHECK((a.points.front() - b.points.front()).norm() < 1e-9);  // the origin stays
      double s = 0;
      for (std::size_t n = 1; n < a.points.size(); ++n) {
        s += (a.points[n] - a.points[n - 1]).norm();
        const double moved = (a.points[n] - b.points[n]).norm();
        // Ramped in from the origin: at most s / 8 of 4 sigma and the sinusoids' 2.8 mm.
        if (s < 8) CHECK(moved <= s / 8 * (4 * t.sigma_mm + 2.8));
        // Past the RCA's straight first part (no wander) and each course's 8 mm ramp.
        if (s > 30) {
          sum_sq += moved * moved;
          ++count;
        }
        CHECK(moved < 6 * t.sigma_mm);
      }
    }
  }
  const double rms = std::sqrt(sum_sq / count);
  CHECK(rms > 0.9 * t.sigma_mm);
  CHECK(rms < 1.2 * t.sigma_mm);
}

TEST_CASE("Tortuosity: the tree stays whole, labelled, and a function of the seed",
          "[anatomy][tortuosity]") {
  TortuosityOptions t;
  t.sigma_mm = 3.0;
  t.correlation_mm = 6;
  const Phantom p = phantom(5, t);
  p.centerlines.validate("tortuosity test");
  // Every child starts on a point of its parent, and every centerline sample is labelled.
  for (const auto& b : p.centerlines.branches) {
    if (b.parent >= 0) {
      double nearest = 1e9;
      for (const auto& q : p.centerlines.branches[b.parent].points)
        nearest = std::min(nearest, (q - b.points.front()).norm());
      CHECK(nearest < 1e-9);
    }
    for (const auto& x : b.points) {
      const Eigen::Vector3d idx = p.label.world_to_index(x);
      const int i = int(std::lround(idx.x())), j = int(std::lround(idx.y())),
                k = int(std::lround(idx.z()));
      REQUIRE(p.label.contains(i, j, k));
      CHECK(p.label(i, j, k) == 1);
    }
  }
  const Phantom again = phantom(5, t);
  CHECK(again.centerlines.branches.size() == p.centerlines.branches.size());
  for (std::size_t k = 0; k < p.centerlines.branches.size(); ++k)
    CHECK(again.centerlines.branches[k].points == p.centerlines.branches[k].points);
  // sigma 0 draws nothing: its correlation length changes nothing.
  TortuosityOptions off;
  off.correlation_mm = 30;
  const Phantom classic = phantom(5, {}), off_phantom = phantom(5, off);
  for (std::size_t k = 0; k < classic.centerlines.branches.size(); ++k)
    CHECK(classic.centerlines.branches[k].points == off_phantom.centerlines.branches[k].points);
}

TEST_CASE("Tortuosity: bad options are named", "[anatomy][tortuosity]") {
  for (double sigma : {-0.1, 5.5, std::nan("")}) {
    TortuosityOptions t;
    t.sigma_mm = sigma;
    CHECK_THROWS_WITH(phantom(1, t), Catch::Contains("TortuosityOptions::sigma_mm"));
  }
  for (double correlation : {0.0, 51.0, std::nan("")}) {
    TortuosityOptions t;
    t.sigma_mm = 1;
    t.correlation_mm = correlation;
    CHECK_THROWS_WITH(phantom(1, t), Catch::Contains("TortuosityOptions::correlation_mm"));
  }
}
