// The geometric matcher's parts: the chain DP against brute force, vesselness at the centre and
// scale of a tube, 2D centerlines, and the matcher on an exact synthetic scene and on degenerate
// input (no vessels, a camera for another image size, epipolar lines along a vessel).
#include <algorithm>
#include <array>
#include <catch2/catch.hpp>
#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <set>
#include <tuple>

#include "gimm/geometry/carm.hpp"
#include "gimm/geometry/epipolar.hpp"
#include "gimm/match/geometric.hpp"

namespace {

/// Dark horizontal bar of half-width `radius` px (a box profile) on a bright background.
gimm::Image<float> bar_image(int size, double radius, double row) {
  gimm::Image<float> im(size, size, 0.9f);
  for (int r = 0; r < size; ++r)
    for (int c = 0; c < size; ++c)
      if (std::abs(r - row) <= radius) im(r, c) = 0.4f;
  return im;
}

gimm::Camerad carm_camera(double primary, double secondary, int size) {
  gimm::CArm g;
  g.primary_deg = primary;
  g.secondary_deg = secondary;
  g.rows = g.cols = size;
  g.pixel_mm = 256.0 / size;
  return g.camera();
}

/// A mask with the projection of a 3D polyline drawn `half` px wide.
gimm::Image<std::uint8_t> draw_curve(const gimm::Camerad& cam,
                                     const std::vector<Eigen::Vector3d>& curve, int half) {
  gimm::Image<std::uint8_t> m(cam.rows(), cam.cols(), 0);
  for (std::size_t k = 0; k + 1 < curve.size(); ++k)
    for (int s = 0; s <= 50; ++s) {
      const Eigen::Vector3d X = curve[k] + (curve[k + 1] - curve[k]) * (s / 50.0);
      const Eigen::Vector2d p = cam.project(X).uv;
      for (int dr = -half; dr <= half; ++dr)
        for (int dc = -half; dc <= half; ++dc) {
          const int r = int(std::lround(p.y())) + dr, c = int(std::lround(p.x())) + dc;
          if (m.contains(r, c)) m(r, c) = 1;
        }
    }
  return m;
}

}  // namespace

TEST_CASE("Chain DP min-marginals equal brute force", "[match][geometric]") {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> cost(0, 5);
  for (int trial = 0; trial < 40; ++trial) {
    const std::size_t n = 2 + trial % 4;
    std::vector<std::size_t> states(n);
    for (auto& s : states) s = 1 + rng() % 3;
    std::vector<std::vector<double>> u(n);
    std::vector<std::vector<std::vector<double>>> p(n);
    for (std::size_t i = 0; i < n; ++i) {
      for (std::size_t s = 0; s < states[i]; ++s) u[i].push_back(cost(rng));
      if (i > 0) {
        p[i].assign(states[i - 1], std::vector<double>(states[i]));
        for (auto& row : p[i])
          for (double& x : row) x = cost(rng);
      }
    }
    const auto unary = [&](std::size_t i, std::size_t s) { return u[i][s]; };
    const auto pair = [&](std::size_t i, std::size_t a, std::size_t b) { return p[i][a][b]; };
    const auto dp = gimm::chain_min_marginals(states, unary, pair);
    CHECK(gimm::chain_min_marginals(states, unary, pair, 0) == dp);  // pair costs not kept
    // Brute force: every state sequence.
    std::vector<std::vector<double>> best(n);
    for (std::size_t i = 0; i < n; ++i) best[i].assign(states[i], 1e300);
    std::vector<std::size_t> seq(n, 0);
    std::function<void(std::size_t, double)> walk = [&](std::size_t i, double total) {
      if (i == n) {
        for (std::size_t k = 0; k < n; ++k) best[k][seq[k]] = std::min(best[k][seq[k]], total);
        return;
      }
      for (std::size_t s = 0; s < states[i]; ++s) {
        seq[i] = s;
        walk(i + 1, total + u[i][s] + (i > 0 ? p[i][seq[i - 1]][s] : 0.0));
      }
    };
    walk(0, 0.0);
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t s = 0; s < states[i]; ++s) CHECK(dp[i][s] == Approx(best[i][s]));
  }
}

namespace {

/// Random 8-connected pixel walks, lengths around the 16-point block size included.
std::vector<gimm::Branch2d> random_walks(std::mt19937& rng) {
  std::vector<gimm::Branch2d> chains;
  for (const int length : {1, 2, 3, 15, 16, 17, 18, 31, 32, 33, 34, 47, 48, 49, 80, 200, 200}) {
    gimm::Branch2d b;
    Eigen::Vector2d p(double(rng() % 100), double(rng() % 100));
    for (int j = 0; j < length; ++j) {
      b.points.push_back(p);
      b.radius_px.push_back(0.5 + (rng() % 40) / 10.0);
      p += Eigen::Vector2d(double(int(rng() % 3) - 1), double(int(rng() % 3) - 1));
    }
    chains.push_back(b);
  }
  return chains;
}

struct MeetingTally {
  std::size_t meetings = 0, exact_hits = 0, near_misses = 0;
};

/// line_meetings() with `index` and without: the same meetings, field by field.
void check_same_meetings(const std::vector<gimm::Branch2d>& chains, const gimm::ChainIndex& index,
                         const Eigen::Vector3d& l, double tol, MeetingTally& tally) {
  static std::vector<double> d;
  std::vector<gimm::LineMeeting> fast, plain;
  // Scratch full of NaN: a read of a distance the fast path did not compute would lose meetings.
  d.assign(d.size(), std::numeric_limits<double>::quiet_NaN());
  gimm::line_meetings(chains, &index, l, tol, d, fast);
  gimm::line_meetings(chains, nullptr, l, tol, d, plain);
  REQUIRE(fast.size() == plain.size());
  for (std::size_t i = 0; i < fast.size(); ++i) {
    CHECK(fast[i].chain == plain[i].chain);
    CHECK(fast[i].along == plain[i].along);
    CHECK(fast[i].b == plain[i].b);
    CHECK(fast[i].radius_px == plain[i].radius_px);
    CHECK(fast[i].distance_px == plain[i].distance_px);
    tally.exact_hits += plain[i].along == std::floor(plain[i].along) && plain[i].distance_px == 0;
    tally.near_misses += plain[i].distance_px > 0;
  }
  tally.meetings += plain.size();
}

}  // namespace

TEST_CASE("Line meetings: the blocked search equals the plain scan", "[match][geometric]") {
  // Random lines and lines through pixel centres (signed distance exactly 0 at chain points).
  std::mt19937 rng(21);
  const std::vector<gimm::Branch2d> chains = random_walks(rng);
  const gimm::ChainIndex index(chains, 3.0);
  CHECK_FALSE(index.has_pencil());
  std::uniform_real_distribution<double> angle(0, 2 * M_PI), offset(-20, 140);
  MeetingTally tally;
  for (int trial = 0; trial < 600; ++trial) {
    Eigen::Vector3d l;
    if (trial % 3 == 0) {  // through a chain point, along x, y or a diagonal
      const auto& c = chains[rng() % chains.size()];
      const Eigen::Vector2d p = c.points[rng() % c.points.size()];
      const Eigen::Vector2d n = trial % 2 ? Eigen::Vector2d(1, 0) : Eigen::Vector2d(0, 1);
      l << n, -n.dot(p);
    } else {
      const double a = angle(rng);
      l << std::cos(a), std::sin(a), -offset(rng);
    }
    for (const double tol : {0.5, 3.0}) check_same_meetings(chains, index, l, tol, tally);
  }
  // Not vacuous: many meetings, some on a chain point exactly, some near misses.
  CHECK(tally.meetings > 2000);
  CHECK(tally.exact_hits > 100);
  CHECK(tally.near_misses > 100);
  std::vector<double> d;
  std::vector<gimm::LineMeeting> out;
  CHECK_THROWS_WITH(gimm::line_meetings(chains, &index, Eigen::Vector3d(1, 0, -5), 3.5, d, out),
                    Catch::Contains("tolerance 3 px") && Catch::Contains("3.5"));
}

TEST_CASE("Line meetings: the pencil index equals the plain scan", "[match][geometric]") {
  // Lines through one point, as epipolar lines are: far off, inside the chains' area (the point
  // in some grown boxes), on a chain point, around the chains near and at infinity (parallel
  // lines).
  std::mt19937 rng(22);
  const std::vector<gimm::Branch2d> chains = random_walks(rng);
  std::vector<Eigen::Vector3d> points = {{2000, -900, 1},
                                         {50, 50, 1},
                                         {chains[5].points[3].x(), chains[5].points[3].y(), 1},
                                         {-4, -1, 1e-9}};
  for (int t = 0; t < 12; ++t) {  // around the chains (some arcs across the angles' +-pi cut)
    const double a = t * M_PI / 6;
    points.emplace_back(50 + 70 * std::cos(a), 50 + 70 * std::sin(a), 1);
    points.emplace_back(50 + 160 * std::cos(a), 50 + 160 * std::sin(a), 1);
    points.emplace_back(std::cos(a), std::sin(a), 0);
  }
  std::uniform_real_distribution<double> coord(-30, 150);
  MeetingTally tally;
  std::size_t reached = 0;
  for (const Eigen::Vector3d& e : points) {
    const gimm::ChainIndex index(chains, 3.0, e);
    REQUIRE(index.has_pencil());
    const double nan = std::numeric_limits<double>::quiet_NaN();
    CHECK(index.chains_for(Eigen::Vector3d(nan, 0, 1)).size() == chains.size());  // no angle
    for (int trial = 0; trial < 100; ++trial) {
      // Through e and a random point, or e and a chain point (crossings exactly at points).
      const auto& c = chains[rng() % chains.size()];
      const Eigen::Vector2d q =
          trial % 2 ? Eigen::Vector2d(coord(rng), coord(rng)) : c.points[rng() % c.points.size()];
      Eigen::Vector3d l = e.cross(q.homogeneous());
      if (!(l.head<2>().norm() > 0)) continue;
      l /= l.head<2>().norm();
      const std::vector<int>& listed = index.chains_for(l);
      reached += listed.size();
      // Selective too: a chain whose box lies 20 px or more beyond the line is not listed.
      for (std::size_t k = 0; k < chains.size(); ++k)
        if (index.blocks(k).box.side_beyond(l, 20.0))
          CHECK(std::find(listed.begin(), listed.end(), int(k)) == listed.end());
      for (const double tol : {0.5, 3.0}) check_same_meetings(chains, index, l, tol, tally);
    }
  }
  CHECK(tally.meetings > 2000);
  CHECK(tally.exact_hits > 100);
  CHECK(tally.near_misses > 100);
  // The index does skip chains: fewer than half of the 17 per line on average (a quarter here).
  INFO("chains looked at: " << reached << " of " << points.size() * 100 * chains.size());
  CHECK(reached < points.size() * 100 * chains.size() / 2);
}

TEST_CASE("Line meetings: the epipole from F", "[match][geometric]") {
  const gimm::Camerad a = carm_camera(30, 0, 256), b = carm_camera(-20, 25, 256);
  const Eigen::Matrix3d F = gimm::fundamental_from_cameras(a, b);
  const auto e = gimm::detail::lines_common_point(F);
  REQUIRE(e);
  // Every epipolar line in B passes through it: B's projection of A's source.
  const Eigen::Vector3d source = b.P() * a.center_homogeneous();
  CHECK(e->cross(source.normalized()).norm() < 1e-9);
  for (const Eigen::Vector2d& x : {Eigen::Vector2d(10, 20), Eigen::Vector2d(200, 90)}) {
    const Eigen::Vector3d l = F * x.homogeneous();
    CHECK(std::abs(l.dot(*e)) < 1e-12 * l.norm());
  }
  // The matcher's use: chains indexed around the epipole of F, searched with lines F a.
  std::mt19937 rng(23);
  std::vector<gimm::Branch2d> chains = random_walks(rng);
  for (auto& c : chains)
    for (auto& p : c.points) p += Eigen::Vector2d(60, 60);  // inside the 256 px view
  const gimm::ChainIndex index(chains, 3.0, e);
  MeetingTally tally;
  std::uniform_real_distribution<double> coord(0, 255);
  for (int trial = 0; trial < 400; ++trial) {
    Eigen::Vector3d l = F * Eigen::Vector3d(coord(rng), coord(rng), 1);
    l /= l.head<2>().norm();
    check_same_meetings(chains, index, l, 3.0, tally);
  }
  CHECK(tally.meetings > 200);
  // A non-finite line is compared with nothing: no meetings, on either path.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  check_same_meetings(chains, index, Eigen::Vector3d(nan, 0, 1), 3.0, tally);
  std::vector<double> d;
  std::vector<gimm::LineMeeting> out;
  gimm::line_meetings(chains, nullptr, Eigen::Vector3d(nan, 0, 1), 3.0, d, out);
  CHECK(out.empty());
  chains[2].points[1].x() = nan;
  CHECK_THROWS_WITH(gimm::ChainIndex(chains, 3.0, e),
                    Catch::Contains("chain 2") && Catch::Contains("non-finite"));
  CHECK_FALSE(gimm::detail::lines_common_point(Eigen::Matrix3d::Zero()));
  Eigen::Matrix3d rank1 = Eigen::Vector3d(1, 2, 3) * Eigen::RowVector3d(0.5, -1, 2);
  CHECK_FALSE(gimm::detail::lines_common_point(rank1));
}

TEST_CASE("Point grid: the matches within a radius, as brute force finds them",
          "[match][geometric]") {
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> coord(-40, 300);
  std::vector<gimm::GeometricMatch> matches(400);
  for (auto& m : matches) m.a = {coord(rng), coord(rng)}, m.b = {coord(rng) / 8, coord(rng) / 8};
  for (const bool by_a : {true, false})
    for (const double cell : {3.0, 6.0}) {
      const gimm::detail::PointGrid grid(matches, by_a, cell);
      for (int q = 0; q < 300; ++q) {
        const Eigen::Vector2d p(coord(rng) / (by_a ? 1 : 8), coord(rng) / (by_a ? 1 : 8));
        std::vector<std::size_t> found, truth;
        grid.visit(p, cell, [&](std::size_t k) { found.push_back(k); });
        for (std::size_t k = 0; k < matches.size(); ++k)
          if (((by_a ? matches[k].a : matches[k].b) - p).norm() <= cell) truth.push_back(k);
        std::sort(found.begin(), found.end());
        CHECK(found == truth);
      }
    }
  const std::vector<gimm::GeometricMatch> none;
  const gimm::detail::PointGrid empty(none, true, 3.0);
  int calls = 0;
  empty.visit({1, 1}, 3.0, [&](std::size_t) { ++calls; });
  CHECK(calls == 0);
}

TEST_CASE("Vesselness peaks on a tube's centre, at the scale of its radius", "[match][geometric]") {
  const double radius = 3.0, row = 32;  // rows 29..35: half-width 3.5 px
  const gimm::Image<float> im = bar_image(64, radius, row);
  gimm::VesselnessOptions o;
  o.scales_px = {1.0, 3.5, 5.0};
  const gimm::Image<float> v = gimm::vesselness(im, o);
  // Across the bar the response is largest at its centre row.
  int best_row = 0;
  for (int r = 0; r < 64; ++r)
    if (v(r, 32) > v(best_row, 32)) best_row = r;
  CHECK(best_row == int(row));
  CHECK(v(int(row), 32) == Approx(1.0f));
  // Among single scales, the one matched to the radius answers most at the centre.
  double best_scale = 0, best_value = -1;
  for (double s : {1.0, 1.75, 2.5, 3.5, 5.0, 7.0}) {
    // vesselness() normalises to its maximum, so compare the s^2-normalised Hessian directly.
    const auto g2 = gimm::detail::gaussian_kernel(s, 2), g0 = gimm::detail::gaussian_kernel(s, 0);
    const gimm::Image<float> hyy = gimm::detail::convolve_separable(im, g0, g2);
    const double value = s * s * hyy(int(row), 32);
    if (value > best_value) best_value = value, best_scale = s;
  }
  CHECK(best_scale == 3.5);
  // A bright bar (not a contrast-filled vessel) gives nothing.
  gimm::Image<float> bright = im;
  for (float& x : bright.storage()) x = 1.3f - x;
  const gimm::Image<float> vb = gimm::vesselness(bright, o);
  CHECK(vb(int(row), 32) == 0.0f);
}

TEST_CASE("Segmentation: a dark bar found, a flat image empty", "[match][geometric]") {
  // Spill beside the bar, in rows: the exact path and the fast one at full resolution 2; the
  // half-resolution scales (the default fast path) widen the mask by up to 1.5 px per side.
  for (const auto& [exact, half_from, spill_rows] :
       {std::tuple{true, 0.0, 2}, std::tuple{false, 0.0, 2}, std::tuple{false, 1.9, 3}}) {
    gimm::SegmentationOptions o;
    o.vesselness.exact_derivatives = exact;
    o.vesselness.half_resolution_from_px = half_from;
    const gimm::Image<std::uint8_t> m = gimm::segment_vessels(bar_image(64, 2.0, 20), o);
    int on_bar = 0, off_bar = 0;
    for (int r = 0; r < 64; ++r)
      for (int c = 0; c < 64; ++c) (std::abs(r - 20) <= 2 ? on_bar : off_bar) += m(r, c);
    INFO("exact " << exact << ", half resolution from " << half_from << " px");
    CHECK(on_bar >= 64 * 3);
    CHECK(off_bar <= 64 * spill_rows);
  }
  const gimm::Image<std::uint8_t> flat = gimm::segment_vessels(gimm::Image<float>(32, 32, 0.5f));
  CHECK(std::count(flat.storage().begin(), flat.storage().end(), 1) == 0);
  CHECK_THROWS_WITH(gimm::vesselness(gimm::Image<float>()), Catch::Contains("empty"));
  gimm::Image<float> nan_image(8, 8, 0.5f);
  nan_image(3, 3) = std::nanf("");
  CHECK_THROWS_WITH(gimm::vesselness(nan_image), Catch::Contains("non-finite"));
}

TEST_CASE("Centerline graph: one chain along a bar, radius from the distance",
          "[match][geometric]") {
  gimm::Image<std::uint8_t> m(40, 60, 0);
  for (int r = 18; r <= 22; ++r)
    for (int c = 5; c <= 54; ++c) m(r, c) = 1;
  const gimm::CenterlineGraph2d g = gimm::centerline_graph(m);
  REQUIRE(g.branches.size() == 1);
  const gimm::Branch2d& b = g.branches[0];
  CHECK(b.points.size() >= 40);
  for (std::size_t k = 0; k < b.points.size(); ++k) {
    CHECK(b.points[k].y() == 20);
    if (k > 0) CHECK((b.points[k] - b.points[k - 1]).norm() <= std::sqrt(2.0) + 1e-12);
  }
  CHECK(b.radius_px[b.points.size() / 2] == Approx(2.5));  // 3 px to the background, minus 0.5
  // A T: three chains meeting at one node.
  for (int r = 22; r <= 38; ++r)
    for (int c = 29; c <= 31; ++c) m(r, c) = 1;
  CHECK(gimm::centerline_graph(m).branches.size() == 3);
}

namespace {

/// Two 3D curves seen from LAO 30 / RAO 30 at 128 px, their masks drawn 3 px wide.
struct TwoCurveScene {
  gimm::Camerad ca = carm_camera(30, 10, 128), cb = carm_camera(-30, -5, 128);
  std::vector<Eigen::Vector3d> dense;  ///< both curves, finely sampled
  gimm::Image<std::uint8_t> ma, mb;

  TwoCurveScene() {
    std::vector<Eigen::Vector3d> c1, c2;
    for (int k = 0; k <= 20; ++k) {
      const double t = k / 20.0;
      c1.emplace_back(-40 + 80 * t, 15 * std::sin(3 * t), 10 * t - 20);
      c2.emplace_back(10 * std::cos(2 * t) - 20, -35 + 70 * t, 25 * t);
    }
    ma = draw_curve(ca, c1, 1);
    mb = draw_curve(cb, c1, 1);
    const auto ma2 = draw_curve(ca, c2, 1), mb2 = draw_curve(cb, c2, 1);
    for (std::size_t i = 0; i < ma.size(); ++i) {
      ma.data()[i] |= ma2.data()[i];
      mb.data()[i] |= mb2.data()[i];
    }
    for (const auto* curve : {&c1, &c2})
      for (std::size_t k = 0; k + 1 < curve->size(); ++k)
        for (int s = 0; s < 100; ++s)
          dense.push_back((*curve)[k] + ((*curve)[k + 1] - (*curve)[k]) * (s / 100.0));
  }

  std::vector<gimm::GeometricMatch> match(const gimm::GeometricOptions& o) const {
    const auto iso = gimm::pair_isocenter(ca, cb);
    return gimm::geometric_matches(gimm::vessel_view(nullptr, &ma, ca, iso, o),
                                   gimm::vessel_view(nullptr, &mb, cb, iso, o), o);
  }

  /// Matches whose b is within 2 px of the projection of the curve point seen at a.
  int on_truth(const std::vector<gimm::GeometricMatch>& matches) const {
    int good = 0;
    for (const auto& m : matches) {
      double best = 1e300;
      Eigen::Vector2d expected = Eigen::Vector2d::Zero();
      for (const auto& X : dense)
        if (const double d = (ca.project(X).uv - m.a).norm(); d < best)
          best = d, expected = cb.project(X).uv;
      good += (m.b - expected).norm() <= 2.0;
    }
    return good;
  }
};

}  // namespace

TEST_CASE("Geometric matcher on an exact scene: matches on the true point", "[match][geometric]") {
  // The matcher must put each b within 2 px of the projection of the 3D point whose A
  // projection is a, and on a's epipolar line.
  const TwoCurveScene scene;
  CHECK(gimm::pair_isocenter(scene.ca, scene.cb).norm() < 1e-6);
  const gimm::GeometricOptions o;
  const auto matches = scene.match(o);
  INFO("matches " << matches.size());
  REQUIRE(matches.size() >= 20);
  for (const auto& m : matches)
    CHECK(gimm::point_line_distance<double>(
              gimm::fundamental_from_cameras(scene.ca, scene.cb) * m.a.homogeneous(), m.b) <=
          o.epipolar_tolerance_px);
  CHECK(scene.on_truth(matches) >= 0.9 * double(matches.size()));
}

TEST_CASE("Geometric matcher: a place where chains meet is reported once", "[match][geometric]") {
  // A skeleton's junction pixel ends each chain that meets there, and each chain samples its
  // ends: the longest chain of A is cut in two chains that start at its middle point.
  const TwoCurveScene scene;
  gimm::GeometricOptions o;
  o.min_confidence = 0;  // every match the DP makes
  const auto iso = gimm::pair_isocenter(scene.ca, scene.cb);
  auto va = gimm::vessel_view(nullptr, &scene.ma, scene.ca, iso, o);
  const auto vb = gimm::vessel_view(nullptr, &scene.mb, scene.cb, iso, o);
  auto& branches = va.graph.branches;
  const auto longest = std::max_element(branches.begin(), branches.end(), [](auto& x, auto& y) {
    return x.points.size() < y.points.size();
  });
  const std::size_t half = longest->points.size() / 2;
  REQUIRE(half >= 10);
  gimm::Branch2d second;
  second.points.assign(longest->points.begin() + long(half), longest->points.end());
  second.radius_px.assign(longest->radius_px.begin() + long(half), longest->radius_px.end());
  longest->points.resize(half + 1);
  longest->radius_px.resize(half + 1);
  std::reverse(longest->points.begin(), longest->points.end());  // both start at the junction
  std::reverse(longest->radius_px.begin(), longest->radius_px.end());
  branches.push_back(second);
  const Eigen::Vector2d shared = branches.back().points.front();
  const auto matches = gimm::geometric_matches(va, vb, o);
  REQUIRE(matches.size() >= 20);
  auto elsewhere = vb;  // the pair's isocentre is computed once: the views must agree on it
  elsewhere.isocenter.x() += 1;
  CHECK_THROWS_WITH(gimm::geometric_matches(va, elsewhere, o),
                    Catch::Contains("different isocentres"));
  std::set<std::array<double, 4>> places;
  int at_shared = 0;
  for (const auto& m : matches) {
    places.insert({m.a.x(), m.a.y(), m.b.x(), m.b.y()});
    at_shared += m.a == shared;
  }
  CHECK(places.size() == matches.size());
  CHECK(at_shared == 1);
}

TEST_CASE("Geometric matcher: margins are thresholded, placement ranks", "[match][geometric]") {
  const TwoCurveScene scene;
  const Eigen::Vector3d iso = gimm::pair_isocenter(scene.ca, scene.cb);
  // The radius term alone: the placement of a match is exp(-r / rank_radius_px), r the A
  // radius at its sample (a flipped sign would rank wide vessels first).
  gimm::GeometricOptions o;
  o.rank_unary = 0, o.rank_chain_end = 0, o.rank_radius_px = 1.5;
  const auto va = gimm::vessel_view(nullptr, &scene.ma, scene.ca, iso, o);
  const auto vb = gimm::vessel_view(nullptr, &scene.mb, scene.cb, iso, o);
  const auto sample_of = [&](const gimm::GeometricMatch& m) {
    const auto& branch = va.graph.branches[static_cast<std::size_t>(m.branch)];
    const auto idx = gimm::detail::resample_chain(branch, o.sample_px);
    return std::pair{idx.size(), idx[static_cast<std::size_t>(m.sample)]};
  };
  auto matches = gimm::geometric_matches(va, vb, o);
  REQUIRE(matches.size() >= 20);
  const double scale =
      gimm::threshold_scale(scene.ca, scene.cb, gimm::pair_isocenter(scene.ca, scene.cb), o);
  for (const auto& m : matches) {
    const auto [n, at] = sample_of(m);
    const double r = va.graph.branches[static_cast<std::size_t>(m.branch)].radius_px[at];
    CHECK(m.placement == Approx(std::exp(-r / 1.5)));
    CHECK(m.confidence == Approx(m.margin * m.placement));
    CHECK(m.margin >= o.min_confidence * scale);  // the threshold is on the margin
  }
  // The chain-end term alone: the first and last two samples of a chain keep exp(-1).
  o.rank_radius_px = 1e12, o.rank_chain_end = 1;
  int ends = 0;
  for (const auto& m : gimm::geometric_matches(va, vb, o)) {
    const auto n = sample_of(m).first;
    const auto k = static_cast<std::size_t>(m.sample);
    const bool end = std::min(k, n - 1 - k) < 2;
    ends += end;
    CHECK(m.placement == Approx(end ? std::exp(-1.0) : 1.0));
  }
  CHECK(ends > 0);
  // The unary term alone: a match further from its line is placed worse.
  o.rank_chain_end = 0, o.rank_unary = 2.5;
  const Eigen::Matrix3d F = gimm::fundamental_from_cameras(scene.ca, scene.cb);
  for (const auto& m : gimm::geometric_matches(va, vb, o)) {
    const double d = gimm::point_line_distance<double>(F * m.a.homogeneous(), m.b);
    CHECK(m.placement <=
          std::exp(-2.5 * o.w_epipolar * std::pow(d / o.epipolar_tolerance_px, 2)) + 1e-9);
  }
  // The long-chain term counts only when a view was segmented: the longer of the A chain and
  // the B chain, in mm at the match's depth, beyond long_chain_mm.
  o.rank_unary = 0, o.long_chain_mm = 20, o.long_chain_decay_mm = 5;
  for (const auto& m : gimm::geometric_matches(va, vb, o)) CHECK(m.placement == Approx(1.0));
  auto sa = va, sb = vb;
  sa.segmented = sb.segmented = true;
  const auto long_ones = gimm::geometric_matches(sa, sb, o);
  REQUIRE(!long_ones.empty());
  int shortened = 0;
  for (const auto& m : long_ones) {
    const double a_mm = gimm::detail::chain_length_px(sa.graph.branches[std::size_t(m.branch)]) /
                        gimm::detail::pixels_per_mm(scene.ca, m.world);
    double b_mm = 0, nearest = 1e300;  // the B chain m.b lies on
    for (const auto& chain : sb.graph.branches)
      for (const auto& p : chain.points)
        if (const double d = (p - m.b).norm(); d < nearest)
          nearest = d, b_mm = gimm::detail::chain_length_px(chain) /
                              gimm::detail::pixels_per_mm(scene.cb, m.world);
    const double excess = std::max(0.0, std::max(a_mm, b_mm) - 20.0);
    shortened += excess > 0;
    CHECK(m.placement == Approx(std::exp(-excess / 5.0)).margin(1e-6));
  }
  CHECK(shortened > 0);
  // Bad ranking options are refused, naming them.
  for (const auto& [u, r, e] :
       {std::tuple{-1.0, 2.0, 1.0}, {2.5, 0.0, 1.0}, {2.5, 2.0, std::nan("")}}) {
    gimm::GeometricOptions bad;
    bad.rank_unary = u, bad.rank_radius_px = r, bad.rank_chain_end = e;
    CHECK_THROWS_WITH(gimm::geometric_matches(va, vb, bad), Catch::Contains("rank_unary"));
  }
}

TEST_CASE("Geometric matcher: the thresholds scale with pixels per mm", "[match][geometric]") {
  gimm::GeometricOptions o;
  const auto scale_at = [&](int px) {
    const gimm::Camerad a = carm_camera(30, 0, px), b = carm_camera(-30, 0, px);
    return gimm::threshold_scale(a, b, gimm::pair_isocenter(a, b), o);
  };
  // The reference is the 256 px phantom geometry (1 mm pixels, SID 1000, SOD 750): scale 1.
  const gimm::Camerad a256 = carm_camera(30, 0, 256), b256 = carm_camera(-30, 0, 256);
  CHECK(gimm::threshold_scale(a256, b256, gimm::pair_isocenter(a256, b256), o) == Approx(1.0));
  // Twice the pixels over the same field: twice the threshold; coarser images keep it.
  CHECK(scale_at(512) == Approx(2.0));
  CHECK(scale_at(384) == Approx(1.5));
  CHECK(scale_at(128) == 1.0);
  o.reference_px_per_mm = 0;  // off: the thresholds as given
  CHECK(scale_at(512) == 1.0);
  // A reference far below the images' raises the threshold past every margin.
  const TwoCurveScene scene;
  o.reference_px_per_mm = 1e-6;
  CHECK(scene.match(o).empty());
  o.reference_px_per_mm = -1;
  CHECK_THROWS_WITH(scene.match(o), Catch::Contains("reference_px_per_mm"));
}

TEST_CASE("Geometric matcher: the ordering term along a B chain", "[match][geometric]") {
  using gimm::detail::Candidate;
  using gimm::detail::ordering_cost;
  const auto on = [](int chain, double along) {
    Candidate c;
    c.chain = chain;
    c.along = along;
    return c;
  };
  const double w = 2.5;
  // Walking forwards: moving on is free, going back costs w, standing still (foreshortening)
  // is free. Flipped direction conventions would swap these.
  CHECK(ordering_cost(on(3, 10), true, on(3, 12.5), true, w) == 0.0);
  CHECK(ordering_cost(on(3, 10), true, on(3, 7), true, w) == w);
  CHECK(ordering_cost(on(3, 10), true, on(3, 10.3), true, w) == 0.0);
  CHECK(ordering_cost(on(3, 10), true, on(3, 9.7), true, w) == 0.0);
  // Walking backwards: the mirror image.
  CHECK(ordering_cost(on(3, 10), false, on(3, 7), false, w) == 0.0);
  CHECK(ordering_cost(on(3, 10), false, on(3, 12.5), false, w) == w);
  // Turning round on one chain costs w; on a new chain any direction is free.
  CHECK(ordering_cost(on(3, 10), true, on(3, 7), false, w) == w);
  CHECK(ordering_cost(on(3, 10), true, on(4, 7), false, w) == 0.0);
  CHECK(ordering_cost(on(3, 10), false, on(4, 70), true, w) == 0.0);

  // With the term on, the exact scene's matches stay on the truth; bad costs are refused.
  const TwoCurveScene scene;
  for (const double order : {1.0, 5.0}) {
    gimm::GeometricOptions o;
    o.w_order = order;
    const auto matches = scene.match(o);
    INFO("order cost " << order << ", " << matches.size() << " matches");
    REQUIRE(matches.size() >= 10);
    CHECK(scene.on_truth(matches) >= 0.9 * double(matches.size()));
  }
  gimm::GeometricOptions bad;
  for (const double order : {-1.0, std::nan(""), HUGE_VAL}) {
    bad.w_order = order;
    CHECK_THROWS_WITH(scene.match(bad), Catch::Contains("ordering cost must be finite and >= 0"));
  }
}

TEST_CASE("Geometric matcher: degenerate input", "[match][geometric]") {
  const int size = 64;
  const gimm::Camerad ca = carm_camera(30, 0, size), cb = carm_camera(-30, 0, size);
  gimm::GeometricOptions o;
  const Eigen::Vector3d iso = gimm::pair_isocenter(ca, cb);
  // No vessels: no matches, no error.
  const gimm::Image<std::uint8_t> empty(size, size, 0);
  const auto va = gimm::vessel_view(nullptr, &empty, ca, iso, o);
  const auto vb = gimm::vessel_view(nullptr, &empty, cb, iso, o);
  CHECK(gimm::geometric_matches(va, vb, o).empty());
  // Tree prior options out of range are refused, naming them.
  for (const auto& [mm, px, reach] :
       {std::tuple{-1.0, 4.0, 6.0}, {5.0, 0.0, 6.0}, {5.0, 4.0, -1.0}, {std::nan(""), 4.0, 6.0}}) {
    gimm::GeometricOptions bad;
    bad.junction_mm = mm, bad.junction_px = px, bad.junction_reach_px = reach;
    CHECK_THROWS_WITH(gimm::geometric_matches(va, vb, bad), Catch::Contains("junction_mm"));
  }
  const gimm::Image<float> flat(size, size, 0.5f);
  CHECK(gimm::vessel_view(&flat, nullptr, ca, iso, o).graph.branches.empty());
  // A camera made for another image size.
  const gimm::Image<std::uint8_t> small(32, 32, 0);
  CHECK_THROWS_WITH(gimm::vessel_view(nullptr, &small, ca, iso, o),
                    Catch::Contains("64 x 64") && Catch::Contains("32 x 32"));
  // Parallel principal axes: no isocentre.
  CHECK_THROWS_WITH(gimm::pair_isocenter(ca, ca), Catch::Contains("parallel"));
  // A vessel along the epipolar lines (its own line crosses it everywhere): the matches it gives
  // are ambiguous, so none is reported at the default confidence.
  const Eigen::Matrix3d F = gimm::fundamental_from_cameras(ca, cb);
  const Eigen::Vector3d l = F * Eigen::Vector2d(32, 32).homogeneous();  // a line in B
  gimm::Image<std::uint8_t> along(size, size, 0);
  for (int c = 2; c < size - 2; ++c) {
    const double r = -(l.x() * c + l.z()) / l.y();
    if (along.contains(int(std::lround(r)), c)) along(int(std::lround(r)), c) = 1;
  }
  gimm::Image<std::uint8_t> across(size, size, 0);
  for (int r = 10; r < 54; ++r) across(r, 32) = 1;
  const auto v_across = gimm::vessel_view(nullptr, &across, ca, iso, o);
  const auto v_along = gimm::vessel_view(nullptr, &along, cb, iso, o);
  REQUIRE(!v_along.graph.branches.empty());
  const auto found = gimm::geometric_matches(v_across, v_along, o);
  CHECK(found.size() <= 3);
}

namespace {

/// A straight chain from p to q, one point per pixel.
gimm::Branch2d straight_chain(Eigen::Vector2d p, Eigen::Vector2d q) {
  gimm::Branch2d b;
  const int n = static_cast<int>(std::ceil((q - p).norm()));
  for (int k = 0; k <= n; ++k) {
    b.points.push_back(p + (q - p) * (double(k) / n));
    b.radius_px.push_back(2.0);
  }
  return b;
}

/// Matches every 2 px along chain `c` of `g`, triangulating at `world` (the same point for all:
/// only the ends' points matter to the tree prior).
void add_chain_matches(const gimm::CenterlineGraph2d& g, int c, const Eigen::Vector3d& world,
                       std::vector<gimm::GeometricMatch>& out) {
  const auto& points = g.branches[static_cast<std::size_t>(c)].points;
  for (std::size_t k = 0; k < points.size(); k += 2) {
    gimm::GeometricMatch m;
    m.a = points[k];
    m.b = points[k];
    m.world = world;
    m.branch = c;
    m.sample = static_cast<int>(k / 2);
    out.push_back(m);
  }
}

}  // namespace

TEST_CASE("Tree prior: a chain whose junction disagrees in depth with all it meets is off",
          "[match][geometric]") {
  gimm::CenterlineGraph2d g;
  g.rows = g.cols = 256;
  // A bifurcation at (50, 80): parent 0, children 1 and 2 (their ends 2.2 px from the parent's).
  g.branches.push_back(straight_chain({50, 50}, {50, 80}));
  g.branches.push_back(straight_chain({51, 82}, {70, 100}));
  g.branches.push_back(straight_chain({49, 82}, {30, 100}));
  // A crossing at (150, 50) of two vessels at different depths: 3 continues into 5, 4 into 6.
  g.branches.push_back(straight_chain({150, 20}, {150, 48}));
  g.branches.push_back(straight_chain({120, 50}, {148, 50}));
  g.branches.push_back(straight_chain({150, 52}, {150, 80}));
  g.branches.push_back(straight_chain({152, 50}, {180, 50}));
  // A chain that meets nothing.
  g.branches.push_back(straight_chain({200, 200}, {220, 220}));
  gimm::GeometricOptions o;  // junction_mm 5, junction_px 4
  const Eigen::Vector3d near(0, 0, 0), deep(0, 0, 30);
  std::vector<gimm::GeometricMatch> m;
  add_chain_matches(g, 0, near, m);
  add_chain_matches(g, 1, near + Eigen::Vector3d(2, 1, 0), m);  // 2.2 mm off: agrees
  add_chain_matches(g, 2, deep, m);                             // 30 mm deeper: off the tree
  add_chain_matches(g, 3, near, m);
  add_chain_matches(g, 4, deep, m);
  add_chain_matches(g, 5, near + Eigen::Vector3d(0, 0, 4), m);  // 4 mm: agrees with 3
  add_chain_matches(g, 6, deep, m);
  add_chain_matches(g, 7, deep, m);
  const std::vector<bool> off = gimm::detail::off_tree_chains(g, m, o);
  CHECK(off == std::vector<bool>{false, false, true, false, false, false, false, false});
  // Wider tolerance: the deep child agrees; narrower: chain 5 no longer agrees with 3.
  o.junction_mm = 40;
  CHECK(gimm::detail::off_tree_chains(g, m, o)[2] == false);
  o.junction_mm = 3;
  CHECK(gimm::detail::off_tree_chains(g, m, o)[5] == true);
  // A junction is judged by the matches at the chain's end: with the deep child's first
  // matches dropped (the nearest now 8 px from its end, beyond junction_reach_px), it meets
  // nothing and stays on.
  o.junction_mm = 5;
  std::vector<gimm::GeometricMatch> trimmed;
  for (const auto& x : m)
    if (x.branch != 2 || x.sample >= 4) trimmed.push_back(x);
  CHECK(gimm::detail::off_tree_chains(g, trimmed, o)[2] == false);
  // A match naming a chain the graph does not have is a caller's bug, said so.
  m.back().branch = 8;
  CHECK_THROWS_WITH(gimm::detail::off_tree_chains(g, m, o), Catch::Contains("chain 8 of 8"));
}
