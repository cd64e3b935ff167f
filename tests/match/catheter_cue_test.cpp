// The catheter cue (match/catheter_cue.hpp): which segmented chains are not vessels. Hand-made
// chains with known straightness, length, calibre and distance to the field's edge; the edge
// distance against brute force; and a segmented image with a catheter-like bar and a vessel.
#include <catch2/catch.hpp>
#include <cmath>
#include <random>

#include "gimm/geometry/carm.hpp"
#include "gimm/match/catheter_cue.hpp"
#include "gimm/match/geometric.hpp"

namespace {

constexpr double kPi = 3.14159265358979323846;

/// A chain along `points` with a radius going linearly from r0 to r1.
gimm::Branch2d chain(const std::vector<Eigen::Vector2d>& points, double r0, double r1) {
  gimm::Branch2d b;
  b.points = points;
  for (std::size_t k = 0; k < points.size(); ++k)
    b.radius_px.push_back(r0 + (r1 - r0) * double(k) / double(points.size() - 1));
  return b;
}

std::vector<Eigen::Vector2d> segment(Eigen::Vector2d from, Eigen::Vector2d to, int n) {
  std::vector<Eigen::Vector2d> p;
  for (int k = 0; k <= n; ++k) p.push_back(from + (to - from) * (double(k) / n));
  return p;
}

/// Arc of `degrees` on a circle of `radius` px about `centre`.
std::vector<Eigen::Vector2d> arc(Eigen::Vector2d centre, double radius, double degrees, int n) {
  std::vector<Eigen::Vector2d> p;
  for (int k = 0; k <= n; ++k) {
    const double t = degrees * kPi / 180 * k / n;
    p.push_back(centre + radius * Eigen::Vector2d(std::cos(t), std::sin(t)));
  }
  return p;
}

gimm::CenterlineGraph2d graph_of(std::vector<gimm::Branch2d> chains) {
  gimm::CenterlineGraph2d g;
  g.rows = g.cols = 200;
  g.branches = std::move(chains);
  return g;
}

}  // namespace

TEST_CASE("Catheter cue: the distance to the field's edge equals brute force",
          "[match][catheter]") {
  std::mt19937 rng(5);
  gimm::Image<std::uint8_t> field(30, 40, 1);
  for (int k = 0; k < 25; ++k) field(int(rng() % 30), int(rng() % 40)) = 0;
  for (int r = -2; r < 32; r += 3)
    for (int c = -2; c < 42; c += 3) {
      int brute = 1000;  // Chebyshev distance to the nearest pixel outside field or image
      for (int rr = -10; rr < 45; ++rr)
        for (int cc = -10; cc < 55; ++cc) {
          const bool out = rr < 0 || cc < 0 || rr >= 30 || cc >= 40 || field(rr, cc) == 0;
          if (out) brute = std::min(brute, std::max(std::abs(rr - r), std::abs(cc - c)));
        }
      const Eigen::Vector2d p(c, r);
      CHECK(gimm::detail::distance_to_field_edge(p, 30, 40, &field, 50) == std::min(brute, 50));
      int no_field = 1000;
      for (int rr = -10; rr < 45; ++rr)
        for (int cc = -10; cc < 55; ++cc)
          if (rr < 0 || cc < 0 || rr >= 30 || cc >= 40)
            no_field = std::min(no_field, std::max(std::abs(rr - r), std::abs(cc - c)));
      CHECK(gimm::detail::distance_to_field_edge(p, 30, 40, nullptr, 50) == std::min(no_field, 50));
    }
}

TEST_CASE("Catheter cue: straight and long, or leaving the field at an even calibre",
          "[match][catheter]") {
  gimm::CatheterCueOptions o;   // 0.95 over 20 mm; ends within 3 px + radius, >= 10 mm, cv <= 0.25
  CHECK(o.field_edge_px == 0);  // the edge cue is off by default
  o.field_edge_px = 3;
  // 100 px straight inside the image: 50 mm at 2 px/mm, 10 mm at 10 px/mm.
  const auto straight = graph_of({chain(segment({50, 50}, {150, 50}, 100), 3, 3)});
  CHECK(gimm::catheter_like_chains(straight, 2.0, nullptr, o) == std::vector<bool>{true});
  CHECK(gimm::catheter_like_chains(straight, 10.0, nullptr, o) == std::vector<bool>{false});
  // A quarter circle of 60 px (chord / length 0.90) is a vessel's curve, however long.
  const auto bent = graph_of({chain(arc({100, 100}, 60, 90, 120), 3, 3)});
  CHECK(gimm::catheter_like_chains(bent, 1.0, nullptr, o) == std::vector<bool>{false});
  // The same arc reaching the image's border (x = 198, 2 px from it) at an even calibre leaves
  // the field; 6 px from it (within 3 px + its radius of 3) too, 8 px not.
  const auto leaving = graph_of({chain(arc({138, 100}, 60, 90, 120), 3, 3)});
  CHECK(gimm::catheter_like_chains(leaving, 1.0, nullptr, o) == std::vector<bool>{true});
  CHECK(gimm::catheter_like_chains(leaving, 1.0, nullptr, {}) == std::vector<bool>{false});
  CHECK(gimm::catheter_like_chains(graph_of({chain(arc({134, 100}, 60, 90, 120), 3, 3)}), 1.0,
                                   nullptr, o) == std::vector<bool>{true});
  CHECK(gimm::catheter_like_chains(graph_of({chain(arc({132, 100}, 60, 90, 120), 3, 3)}), 1.0,
                                   nullptr, o) == std::vector<bool>{false});
  // ...and a tapering one (radius 5 -> 1 px, coefficient of variation 0.38) is a vessel.
  const auto tapering = graph_of({chain(arc({138, 100}, 60, 90, 120), 5, 1)});
  CHECK(gimm::catheter_like_chains(tapering, 1.0, nullptr, o) == std::vector<bool>{false});
  // ...and so is one too short to tell (60 px at 10 px/mm: 6 mm < 10 mm; at 1 px/mm it leaves).
  const auto short_one = graph_of({chain(arc({160, 100}, 38, 90, 60), 3, 3)});
  CHECK(gimm::catheter_like_chains(short_one, 1.0, nullptr, o) == std::vector<bool>{true});
  CHECK(gimm::catheter_like_chains(short_one, 10.0, nullptr, o) == std::vector<bool>{false});
  // The field's edge counts like the border: a field ending at column 120, the arc ending there.
  gimm::Image<std::uint8_t> field(200, 200, 0);
  for (int r = 0; r < 200; ++r)
    for (int c = 0; c <= 120; ++c) field(r, c) = 1;
  const auto to_field = graph_of({chain(arc({60, 100}, 60, 90, 120), 3, 3)});
  CHECK(gimm::catheter_like_chains(to_field, 1.0, nullptr, o) == std::vector<bool>{false});
  CHECK(gimm::catheter_like_chains(to_field, 1.0, &field, o) == std::vector<bool>{true});
  // Both cues off.
  gimm::CatheterCueOptions off;
  off.min_length_mm = 0;
  off.field_edge_px = 0;
  CHECK(gimm::catheter_like_chains(straight, 2.0, nullptr, off) == std::vector<bool>{false});
  CHECK(gimm::catheter_like_chains(leaving, 1.0, nullptr, off) == std::vector<bool>{false});
  // Dropping keeps the others in order.
  auto mixed = graph_of({chain(arc({100, 100}, 60, 90, 120), 3, 3),
                         chain(segment({50, 50}, {150, 50}, 100), 3, 3),
                         chain(arc({100, 100}, 40, 90, 80), 2, 2)});
  const std::size_t arc_points = mixed.branches[2].points.size();
  CHECK(gimm::drop_catheter_like_chains(mixed, 2.0, nullptr, o) == 1);
  REQUIRE(mixed.branches.size() == 2);
  CHECK(mixed.branches[1].points.size() == arc_points);
}

TEST_CASE("Catheter cue: bad options are named", "[match][catheter]") {
  const auto g = graph_of({chain(segment({50, 50}, {150, 50}, 100), 3, 3)});
  gimm::CatheterCueOptions o;
  o.straightness = 1.5;
  CHECK_THROWS_WITH(gimm::catheter_like_chains(g, 2.0, nullptr, o),
                    Catch::Contains("straightness must be in (0, 1]") && Catch::Contains("1.5"));
  o = {};
  o.field_edge_px = -1;
  CHECK_THROWS_WITH(gimm::catheter_like_chains(g, 2.0, nullptr, o), Catch::Contains("-1"));
  CHECK_THROWS_WITH(gimm::catheter_like_chains(g, 0.0, nullptr, {}),
                    Catch::Contains("pixels per mm must be finite and > 0, got 0"));
}

TEST_CASE("Catheter cue: a segmented catheter-like bar is dropped, the curved vessel kept",
          "[match][catheter]") {
  // 256 px: a dark straight bar from the top edge to the bottom edge at column 40 (the
  // catheter's shaft) and a dark S-shaped vessel in the middle, on a bright background.
  const int n = 256;
  gimm::Image<float> image(n, n, 0.9f);
  for (int r = 0; r < n; ++r)
    for (int c = 36; c <= 44; ++c) image(r, c) = 0.35f;
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) {
      const double t = (r - 60) / 140.0;  // rows 60..200
      if (t < 0 || t > 1) continue;
      const double centre = 150 + 35 * std::sin(2 * kPi * t);
      if (std::abs(c - centre) <= 3) image(r, c) = 0.45f;
    }
  gimm::CArm g;
  g.rows = g.cols = n;
  g.pixel_mm = 0.4;
  const gimm::Camerad camera = g.camera();
  const Eigen::Vector3d iso = Eigen::Vector3d::Zero();
  gimm::GeometricOptions o;
  const gimm::VesselView kept = gimm::vessel_view(&image, nullptr, camera, iso, o);
  CHECK(kept.catheter_chains >= 1);
  REQUIRE(!kept.graph.branches.empty());
  for (const gimm::Branch2d& b : kept.graph.branches)
    for (const Eigen::Vector2d& p : b.points) CHECK(p.x() > 80);  // nothing left on the bar
  o.catheter.min_length_mm = 0;
  o.catheter.field_edge_px = 0;
  const gimm::VesselView all = gimm::vessel_view(&image, nullptr, camera, iso, o);
  CHECK(all.catheter_chains == 0);
  bool bar = false;
  for (const gimm::Branch2d& b : all.graph.branches)
    for (const Eigen::Vector2d& p : b.points) bar = bar || std::abs(p.x() - 40) < 3;
  CHECK(bar);
}
