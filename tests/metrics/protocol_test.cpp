// The evaluation protocol on hand-computed cases: both directions, the mask filter, top-K and
// its ties, coverage, percentiles, the exact-geometry check, degenerate inputs, and breakdowns
// that add up to the pooled figures.
#include <catch2/catch.hpp>
#include <cmath>
#include <memory>

#include "gimm/metrics/summary.hpp"

namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;
using gimm::Correspondence;
using gimm::Image;

Correspondence label(Vector2d a, Vector2d b, Vector3d world) {
  Correspondence c;
  c.a = a;
  c.b = b;
  c.world = world;
  return c;
}

/// Three labels, 64 x 64 masks that are vessel everywhere except pixel (row 50, col 50) of A
/// and pixel (row 5, col 5) of B; F of a horizontal translation (v_b = v_a).
gimm::PairTruth small_truth() {
  gimm::PairTruth t;
  t.id = "p/RCA_00-01";
  t.view_a = "RCA_00";
  t.view_b = "RCA_01";
  t.view_class_a = 1;
  t.view_class_b = 2;
  t.dense = {label({10, 10}, {20, 10}, {0, 0, 0}), label({30, 10}, {40, 10}, {10, 0, 0}),
             label({10, 30}, {20, 30}, {0, 10, 0})};
  Image<std::uint8_t> ma(64, 64, 255), mb(64, 64, 255);
  ma(50, 50) = 0;
  mb(5, 5) = 0;
  t.mask_a = std::make_shared<const Image<std::uint8_t>>(ma);
  t.mask_b = std::make_shared<const Image<std::uint8_t>>(mb);
  t.F << 0, 0, 0, 0, 0, -1, 0, 1, 0;
  return t;
}

/// m0 and m1 scored both ways; m2's A point rounds to (50, 50), off mask A; m3's B point
/// rounds to (5, 5), off mask B, and m3 has the lowest confidence.
gimm::PairMatches small_matches() {
  gimm::PairMatches m;
  m.pair = "p/RCA_00-01";
  m.add({11, 10}, {22, 10}, 0.9);
  m.add({29, 10}, {20, 12}, 0.8);
  m.add({50.4, 49.6}, {20, 29}, 0.7);
  m.add({10, 31}, {5.4, 4.6}, 0.1);
  return m;
}

}  // namespace

TEST_CASE("Each direction: nearest source label, its partner, 2D and 3D errors", "[metrics]") {
  const auto score = gimm::score_pair(small_truth(), small_matches());
  REQUIRE(score.ranked.size() == 4);
  REQUIRE(score.system == "RCA");
  REQUIRE(score.class_pair == "RCA AP Cranial / LAO");
  const auto& r = score.ranked;
  CHECK(r[0].index == 0);
  CHECK(r[3].index == 3);
  // m0: A->B expects (20,10), got (22,10); B->A expects (10,10), got (11,10); same 3D point.
  CHECK(r[0].ab.scored);
  CHECK(r[0].ab.error_px == Approx(2.0));
  CHECK(r[0].ab.error_mm == Approx(0.0).margin(1e-12));
  CHECK(r[0].ba.error_px == Approx(1.0));
  CHECK(r[0].ba.error_mm == Approx(0.0).margin(1e-12));
  // m1: A->B expects (40,10), got (20,12), nearest B label is L0 -> 10 mm; B->A expects
  // (10,10), got (29,10), nearest A label L1 -> 10 mm.
  CHECK(r[1].ab.error_px == Approx(std::sqrt(404.0)));
  CHECK(r[1].ab.error_mm == Approx(10.0));
  CHECK(r[1].ba.error_px == Approx(19.0));
  CHECK(r[1].ba.error_mm == Approx(10.0));
  // m2: A side off mask A -> A->B dropped; B->A expects (10,30) from L2, got (50.4,49.6),
  // whose nearest A label is L1: |(0,10,0) - (10,0,0)|.
  CHECK_FALSE(r[2].ab.scored);
  CHECK(std::isnan(r[2].ab.error_px));
  CHECK(r[2].ba.scored);
  CHECK(r[2].ba.error_px == Approx(std::sqrt(40.4 * 40.4 + 19.6 * 19.6)));
  CHECK(r[2].ba.error_mm == Approx(std::sqrt(200.0)));
  // m3: B side off mask B -> B->A dropped; A->B expects (20,30), got (5.4,4.6) (nearest L0).
  CHECK(r[3].ab.error_px == Approx(std::sqrt(14.6 * 14.6 + 25.4 * 25.4)));
  CHECK(r[3].ab.error_mm == Approx(10.0));
  CHECK_FALSE(r[3].ba.scored);
  // Exact-geometry check: |dv| in both images, summed in squares.
  CHECK(r[0].epipolar_px == Approx(0.0).margin(1e-12));
  CHECK(r[1].epipolar_px == Approx(std::sqrt(8.0)));
  CHECK(r[2].epipolar_px == Approx(20.6 * std::sqrt(2.0)));
}

TEST_CASE("Top-K summary: precision, means, coverage, percentiles, epipolar", "[metrics]") {
  const std::vector<gimm::PairScore> pairs = {gimm::score_pair(small_truth(), small_matches())};
  const double e2 = std::sqrt(404.0), e5 = std::sqrt(40.4 * 40.4 + 19.6 * 19.6);
  SECTION("K = 3 keeps m0, m1, m2: five scored direction-matches of six") {
    const auto s = gimm::summarize(pairs, 3);
    CHECK(s.pairs == 1);
    CHECK(s.matches == 4);
    CHECK(s.kept == 3);
    CHECK(s.slots == 6);
    CHECK(s.scored == 5);
    CHECK(s.coverage == Approx(5.0 / 6));
    // errors px {2, 1, e2, 19, e5}
    CHECK(s.prec[0] == Approx(0.2));
    CHECK(s.prec[1] == Approx(0.4));
    CHECK(s.prec[2] == Approx(0.4));
    CHECK(s.mean_px == Approx((2 + 1 + e2 + 19 + e5) / 5));
    CHECK(s.median_px == Approx(19.0));
    CHECK(s.p90_px == Approx(e2 + 0.6 * (e5 - e2)));
    CHECK(s.mean_mm == Approx((0 + 0 + 10 + 10 + std::sqrt(200.0)) / 5));
    CHECK(s.median_mm == Approx(10.0));
    CHECK(s.epipolar_count == 3);
    CHECK(s.epipolar_mean_px == Approx((std::sqrt(8.0) + 20.6 * std::sqrt(2.0)) / 3));
    CHECK(s.epipolar_median_px == Approx(std::sqrt(8.0)));
    CHECK(s.epipolar_ok == Approx(1.0 / 3));
  }
  SECTION("K larger than the match count: all kept, coverage over 2K") {
    const auto s = gimm::summarize(pairs, 20);
    CHECK(s.kept == 4);
    CHECK(s.slots == 40);
    CHECK(s.scored == 6);
    CHECK(s.coverage == Approx(6.0 / 40));
  }
  SECTION("K = 0 means all matches, coverage over 2 x matches") {
    const auto s = gimm::summarize(pairs, 0);
    CHECK(s.kept == 4);
    CHECK(s.slots == 8);
    CHECK(s.coverage == Approx(0.75));
  }
  SECTION("K = 1 keeps the most confident only") {
    const auto s = gimm::summarize(pairs, 1);
    CHECK(s.scored == 2);
    CHECK(s.mean_px == Approx(1.5));
    CHECK(s.prec[0] == Approx(0.5));
    CHECK(s.prec[1] == Approx(1.0));
  }
}

TEST_CASE("Ranking: descending confidence, ties by index; top-K takes the first K", "[metrics]") {
  CHECK(gimm::rank_by_confidence({0.5, 0.9, 0.5, 0.9, 0.1}) ==
        std::vector<std::size_t>{1, 3, 0, 2, 4});
  CHECK(gimm::rank_by_confidence({0.5, 0.9, 0.5, 0.9, 0.1}, 3) ==
        std::vector<std::size_t>{1, 3, 0});
  CHECK(gimm::rank_by_confidence({1.0, 2.0}, 10) == std::vector<std::size_t>{1, 0});
  CHECK(gimm::rank_by_confidence({}, 5).empty());
  // The off-mask match is ranked first: K = 1 scores only its B->A direction.
  auto m = small_matches();
  m.confidence = {0.1, 0.1, 0.95, 0.1};
  const auto s = gimm::summarize({gimm::score_pair(small_truth(), m)}, 1);
  CHECK(s.scored == 1);
  CHECK(s.coverage == Approx(0.5));
}

TEST_CASE("Degenerate inputs give defined results", "[metrics]") {
  SECTION("no matches") {
    const auto s = gimm::summarize({gimm::score_pair(small_truth(), gimm::PairMatches{})}, 20);
    CHECK(s.kept == 0);
    CHECK(s.slots == 40);
    CHECK(s.scored == 0);
    CHECK(s.coverage == 0.0);
    CHECK(std::isnan(s.prec[0]));
    CHECK(std::isnan(s.mean_px));
    CHECK(std::isnan(s.median_mm));
    CHECK(std::isnan(s.epipolar_mean_px));
    const auto j = gimm::to_json(s);
    CHECK(j.at("mean_px").is_null());
    CHECK(gimm::fmt(s.mean_px) == "-");
    const auto all = gimm::summarize({gimm::score_pair(small_truth(), gimm::PairMatches{})}, 0);
    CHECK(all.slots == 0);
    CHECK(std::isnan(all.coverage));
  }
  SECTION("every source off the mask") {
    auto t = small_truth();
    t.mask_a = std::make_shared<const Image<std::uint8_t>>(64, 64, 0);
    t.mask_b = std::make_shared<const Image<std::uint8_t>>(64, 64, 0);
    const auto s = gimm::summarize({gimm::score_pair(t, small_matches())}, 20);
    CHECK(s.scored == 0);
    CHECK(s.coverage == 0.0);
    CHECK(std::isnan(s.mean_mm));
    CHECK(s.epipolar_count == 4);  // the geometry check does not depend on the masks
  }
  SECTION("sources off the image and on a half-pixel boundary") {
    const Image<std::uint8_t> mask(4, 4, 255);
    CHECK(gimm::on_mask(&mask, {3.49, 0}));
    CHECK_FALSE(gimm::on_mask(&mask, {3.5, 0}));  // rounds to column 4
    CHECK(gimm::on_mask(&mask, {-0.49, 0}));
    CHECK_FALSE(gimm::on_mask(&mask, {-0.5, 0}));  // rounds to column -1
    CHECK_FALSE(gimm::on_mask(&mask, {1e300, 0}));
    CHECK_FALSE(gimm::on_mask(&mask, {std::nan(""), 0}));
    CHECK(gimm::on_mask(nullptr, {-5, 7}));
  }
  SECTION("a pair without labels scores nothing") {
    auto t = small_truth();
    t.dense.clear();
    const auto s = gimm::summarize({gimm::score_pair(t, small_matches())}, 20);
    CHECK(s.scored == 0);
    CHECK(s.kept == 4);
  }
  SECTION("a missing predictions file is a pair with no matches") {
    const auto s = gimm::summarize({gimm::missing_pair(small_truth())}, 20);
    CHECK(s.missing == 1);
    CHECK(s.slots == 40);
    CHECK(s.coverage == 0.0);
  }
}

TEST_CASE("Percentiles interpolate linearly between order statistics", "[metrics]") {
  CHECK(gimm::percentile({4, 1, 3, 2}, 0.5) == Approx(2.5));
  CHECK(gimm::percentile({4, 1, 3, 2}, 0.9) == Approx(3.7));
  CHECK(gimm::percentile({7}, 0.9) == 7.0);
  CHECK(gimm::percentile({1, 2}, 0.0) == 1.0);
  CHECK(gimm::percentile({1, 2}, 1.0) == 2.0);
  CHECK(std::isnan(gimm::percentile({}, 0.5)));
}

TEST_CASE("Breakdowns by system and class pair add up to the pooled figures", "[metrics]") {
  gimm::Rng rng(3);
  std::vector<gimm::PairScore> pairs;
  const char* views[][2] = {{"RCA_00", "RCA_01"},
                            {"LCA_00", "LCA_02"},
                            {"LCA_01", "LCA_02"},
                            {"LCA_00", "LCA_02"},
                            {"RCA_01", "RCA_03"}};
  const int classes[][2] = {{1, 2}, {5, 7}, {6, 7}, {5, 7}, {2, 4}};
  for (int p = 0; p < 5; ++p) {
    auto t = small_truth();
    t.id = "p/" + std::to_string(p);
    t.view_a = views[p][0];
    t.view_b = views[p][1];
    t.view_class_a = classes[p][0];
    t.view_class_b = classes[p][1];
    gimm::PairMatches m;
    const int n = 3 + 7 * p;  // some pairs have fewer than K = 20 matches
    for (int i = 0; i < n; ++i)
      m.add({rng.uniform(0, 64), rng.uniform(0, 64)}, {rng.uniform(0, 64), rng.uniform(0, 64)},
            rng.uniform());
    pairs.push_back(gimm::score_pair(t, m));
  }
  pairs.push_back(gimm::missing_pair(small_truth()));
  for (long k : {20L, 5L, 0L}) {
    const auto pooled = gimm::summarize(pairs, k);
    for (const auto& groups :
         {gimm::summarize_by(pairs, k, [](const gimm::PairScore& p) { return p.system; }),
          gimm::summarize_by(pairs, k, [](const gimm::PairScore& p) { return p.class_pair; })}) {
      std::size_t n_pairs = 0, kept = 0, slots = 0, scored = 0, epi = 0;
      double sum_px = 0, sum_mm = 0, sum_p3 = 0, sum_epi = 0;
      for (const auto& [key, s] : groups) {
        n_pairs += s.pairs;
        kept += s.kept;
        slots += s.slots;
        scored += s.scored;
        epi += s.epipolar_count;
        if (s.scored > 0) {
          sum_px += s.mean_px * s.scored;
          sum_mm += s.mean_mm * s.scored;
          sum_p3 += s.prec[1] * s.scored;
        }
        if (s.epipolar_count > 0) sum_epi += s.epipolar_mean_px * s.epipolar_count;
      }
      CHECK(n_pairs == pooled.pairs);
      CHECK(kept == pooled.kept);
      CHECK(slots == pooled.slots);
      CHECK(scored == pooled.scored);
      CHECK(epi == pooled.epipolar_count);
      REQUIRE(pooled.scored > 0);
      CHECK(sum_px / scored == Approx(pooled.mean_px));
      CHECK(sum_mm / scored == Approx(pooled.mean_mm));
      CHECK(sum_p3 / scored == Approx(pooled.prec[1]));
      CHECK(sum_epi / epi == Approx(pooled.epipolar_mean_px));
    }
  }
  const auto by_class =
      gimm::summarize_by(pairs, 20, [](const gimm::PairScore& p) { return p.class_pair; });
  CHECK(by_class.count("LCA AP / AP Caudal") == 1);
  CHECK(by_class.at("LCA AP / AP Caudal").pairs == 2);
}

TEST_CASE("Top-K curve points", "[metrics]") {
  std::vector<gimm::PairScore> pairs(2);
  pairs[0].matches = 300;
  pairs[1].matches = 7;
  CHECK(gimm::curve_ks(pairs, 20) == std::vector<long>{5, 10, 20, 50, 100, 200, 0});
  CHECK(gimm::curve_ks(pairs, 30) == std::vector<long>{5, 10, 20, 30, 50, 100, 200, 0});
  pairs[0].matches = 4;
  CHECK(gimm::curve_ks(pairs, 20) == std::vector<long>{5, 20, 0});
}

TEST_CASE("Summary JSON round trip", "[metrics]") {
  const auto s = gimm::summarize({gimm::score_pair(small_truth(), small_matches())}, 3);
  const auto back = gimm::summary_from_json(gimm::to_json(s));
  CHECK(back.scored == s.scored);
  CHECK(back.slots == s.slots);
  CHECK(back.mean_px == s.mean_px);
  CHECK(back.prec[1] == s.prec[1]);
  CHECK(back.epipolar_ok == s.epipolar_ok);
  CHECK(gimm::markdown_row("x", back) == gimm::markdown_row("x", s));
}
