// Epipolar gating (the paper's defaults tau = delta = 2 px):
//   hard:  keep iff d2 <= delta^2, dropped confidences become 0;
//   soft:  c exp(-d2 / tau^2);   logit: c sigmoid(-d2 / tau^2);   none: unchanged;
// d2 the squared symmetric epipolar distance. tau = delta = 3 below, so that tau vs tau^2 and
// delta vs delta^2 (or distance vs squared distance) give different answers.
#include <catch2/catch.hpp>
#include <cmath>

#include "gimm/geometry/gating.hpp"
#include "scene.hpp"

// Its own namespace: the tests are compiled as one file (tests/CMakeLists.txt).
namespace gating_test {

using namespace gimm;
using Catch::Matchers::Contains;
using gimm_test::carm_pose;

namespace {

/// Epipolar lines are image rows: d2 = 2 (v_a - v_b)^2.
Eigen::Matrix3d rows_F() {
  Eigen::Matrix3d F;
  F << 0, 0, 0,  //
      0, 0, -1,  //
      0, 1, 0;
  return F;
}

/// Five matches with row offsets 0, 1, 2, 2.5, 5 px: d2 = 0, 2, 8, 12.5, 50 px^2.
struct RowMatches {
  Points2<double> x_a{2, 5}, x_b{2, 5};
  VectorX<double> confidence{5};
  VectorX<double> d2{5};
  RowMatches() {
    const double dv[] = {0, 1, 2, 2.5, 5};
    for (int i = 0; i < 5; ++i) {
      x_a.col(i) = Eigen::Vector2d(10 + 20 * i, 100 + 7 * i);
      x_b.col(i) = Eigen::Vector2d(300 - 15 * i, 100 + 7 * i + dv[i]);
      confidence(i) = 0.5 + 0.1 * i;
      d2(i) = 2 * dv[i] * dv[i];
    }
  }
};

GateOptions options_for(GateMode mode) {
  GateOptions o;
  o.mode = mode;
  o.tau = 3.0;
  o.delta_px = 3.0;
  return o;
}

}  // namespace

TEST_CASE("Gate defaults are the paper's", "[geometry][gating]") {
  const GateOptions o;
  CHECK(o.mode == GateMode::hard);
  CHECK(o.tau == 2.0);
  CHECK(o.delta_px == 2.0);
  CHECK_NOTHROW(o.validate());
}

TEST_CASE("gate_factor follows the documented formulas", "[geometry][gating]") {
  const GateOptions o = options_for(GateMode::hard);  // tau = delta = 3 px
  // hard: d2 <= delta^2 = 9 (inclusive), not d2 <= delta or d <= delta^2.
  CHECK(gate_factor(GateMode::hard, 0.0, o) == 1.0);
  CHECK(gate_factor(GateMode::hard, 8.99, o) == 1.0);
  CHECK(gate_factor(GateMode::hard, 9.0, o) == 1.0);
  CHECK(gate_factor(GateMode::hard, 9.01, o) == 0.0);
  CHECK(gate_factor(GateMode::hard, 50.0, o) == 0.0);
  // soft: exp(-d2 / tau^2).
  CHECK(gate_factor(GateMode::soft, 0.0, o) == 1.0);
  CHECK(gate_factor(GateMode::soft, 9.0, o) == Approx(std::exp(-1.0)));
  CHECK(gate_factor(GateMode::soft, 4.5, o) == Approx(std::exp(-0.5)));
  // logit: sigmoid(-d2 / tau^2) = 1 / (1 + exp(d2 / tau^2)); a perfect match gets 1/2.
  CHECK(gate_factor(GateMode::logit, 0.0, o) == Approx(0.5));
  CHECK(gate_factor(GateMode::logit, 9.0, o) == Approx(1.0 / (1.0 + std::exp(1.0))));
  CHECK(gate_factor(GateMode::logit, 18.0, o) == Approx(0.11920292202211755));
  CHECK(gate_factor(GateMode::logit, 1e6, o) == Approx(0).margin(1e-300));
  // none: 1 at any distance.
  CHECK(gate_factor(GateMode::none, 1e9, o) == 1.0);
  // Infinite distance (no epipolar line): dropped or zeroed by every real gate.
  const double inf = std::numeric_limits<double>::infinity();
  CHECK(gate_factor(GateMode::hard, inf, o) == 0.0);
  CHECK(gate_factor(GateMode::soft, inf, o) == 0.0);
  CHECK(gate_factor(GateMode::logit, inf, o) == 0.0);
}

TEST_CASE("gate_with_fundamental on matches at known distances", "[geometry][gating]") {
  const RowMatches m;
  const Eigen::Matrix3d F = rows_F();
  SECTION("hard") {
    const auto r =
        gate_with_fundamental<double>(F, m.x_a, m.x_b, m.confidence, options_for(GateMode::hard));
    REQUIRE(r.F);
    CHECK(*r.F == F);
    for (int i = 0; i < 5; ++i) CHECK(r.distance_sq(i) == Approx(m.d2(i)));
    // d2 = 0, 2, 8 <= 9 kept unchanged; 12.5 and 50 dropped to 0.
    CHECK(r.keep == std::vector<char>{1, 1, 1, 0, 0});
    CHECK(r.confidence(0) == m.confidence(0));
    CHECK(r.confidence(1) == m.confidence(1));
    CHECK(r.confidence(2) == m.confidence(2));
    CHECK(r.confidence(3) == 0);
    CHECK(r.confidence(4) == 0);
  }
  SECTION("soft") {
    const auto r =
        gate_with_fundamental<double>(F, m.x_a, m.x_b, m.confidence, options_for(GateMode::soft));
    CHECK(r.keep == std::vector<char>(5, 1));
    for (int i = 0; i < 5; ++i)
      CHECK(r.confidence(i) == Approx(m.confidence(i) * std::exp(-m.d2(i) / 9.0)));
  }
  SECTION("logit") {
    const auto r =
        gate_with_fundamental<double>(F, m.x_a, m.x_b, m.confidence, options_for(GateMode::logit));
    CHECK(r.keep == std::vector<char>(5, 1));
    for (int i = 0; i < 5; ++i)
      CHECK(r.confidence(i) == Approx(m.confidence(i) / (1.0 + std::exp(m.d2(i) / 9.0))));
    CHECK(r.confidence(0) == Approx(0.5 * m.confidence(0)));
  }
  SECTION("none") {
    const auto r =
        gate_with_fundamental<double>(F, m.x_a, m.x_b, m.confidence, options_for(GateMode::none));
    CHECK(r.keep == std::vector<char>(5, 1));
    CHECK(r.confidence == m.confidence);
    for (int i = 0; i < 5; ++i) CHECK(r.distance_sq(i) == Approx(m.d2(i)));
  }
  SECTION("the scale and sign of F do not matter") {
    const auto r = gate_with_fundamental<double>(Eigen::Matrix3d(-40 * F), m.x_a, m.x_b,
                                                 m.confidence, options_for(GateMode::soft));
    for (int i = 0; i < 5; ++i) CHECK(r.distance_sq(i) == Approx(m.d2(i)));
  }
}

TEST_CASE("gate_with_fundamental with the exact F of two C-arm views", "[geometry][gating]") {
  const Camerad a = carm_pose(30, 20).camera(), b = carm_pose(-30, -15).camera();
  const Eigen::Matrix3d F = fundamental_from_cameras(a, b);
  auto scene = gimm_test::make_pair_scene(a, b, 20, 4);
  // Shift the last 5 matches 10 px along the image-B normal of their epipolar lines.
  for (Eigen::Index i = 15; i < 20; ++i) {
    const Eigen::Vector3d l = F * scene.x_a.col(i).homogeneous();
    scene.x_b.col(i) += 10 * l.head<2>().normalized();
  }
  const VectorX<double> c = VectorX<double>::Ones(20);
  const auto r = gate_with_fundamental<double>(F, scene.x_a, scene.x_b, c);  // defaults
  for (Eigen::Index i = 0; i < 20; ++i) {
    CAPTURE(i);
    CHECK(r.keep[static_cast<std::size_t>(i)] == (i < 15 ? 1 : 0));
    CHECK(r.confidence(i) == (i < 15 ? 1.0 : 0.0));
    if (i >= 15) CHECK(r.distance_sq(i) > 100);  // at least the 10 px in B, squared
  }
}

TEST_CASE("Gate options and inputs are validated", "[geometry][gating]") {
  const RowMatches m;
  const Eigen::Matrix3d F = rows_F();
  GateOptions o;
  o.tau = 0;
  CHECK_THROWS_WITH(o.validate(), Contains("tau") && Contains("got 0"));
  o = {};
  o.tau = std::nan("");
  CHECK_THROWS_AS(o.validate(), Error);
  o = {};
  o.delta_px = -1;
  CHECK_THROWS_WITH(o.validate(), Contains("delta_px") && Contains("got -1"));
  o = {};
  o.delta_px = 0;
  CHECK_NOTHROW(o.validate());
  o = {};
  o.top_k = 7;
  CHECK_THROWS_WITH(o.validate(), Contains("top_k") && Contains("got 7"));
  o = {};
  o.min_matches = 4;
  CHECK_THROWS_WITH(o.validate(), Contains("min_matches") && Contains("got 4"));
  o = {};
  o.tau = -2;
  CHECK_THROWS_AS(gate_with_fundamental<double>(F, m.x_a, m.x_b, m.confidence, o), Error);
  CHECK_THROWS_AS(gate_reference<double>(m.x_a, m.x_b, m.confidence, o), Error);
  // Sizes, confidences (as weights: finite and >= 0), F.
  CHECK_THROWS_AS(gate_with_fundamental<double>(F, m.x_a, m.x_b, VectorX<double>::Ones(4)), Error);
  CHECK_THROWS_AS(
      gate_with_fundamental<double>(F, m.x_a, Points2<double>(m.x_b.leftCols(4)), m.confidence),
      Error);
  VectorX<double> c = m.confidence;
  c(2) = -0.1;
  CHECK_THROWS_WITH(gate_with_fundamental<double>(F, m.x_a, m.x_b, c), Contains("weight 2"));
  Eigen::Matrix3d bad_F = F;
  bad_F(0, 0) = std::nan("");
  CHECK_THROWS_WITH(gate_with_fundamental<double>(bad_F, m.x_a, m.x_b, m.confidence),
                    Contains("non-finite"));
}

TEST_CASE("Gate mode names round trip", "[geometry][gating]") {
  for (GateMode mode : {GateMode::none, GateMode::hard, GateMode::soft, GateMode::logit})
    CHECK(parse_gate_mode(to_string(mode)) == mode);
  CHECK(std::string(to_string(GateMode::logit)) == "logit");
  CHECK_THROWS_WITH(parse_gate_mode("Hard"), Contains("'Hard'") && Contains("none|hard"));
  CHECK_THROWS_AS(parse_gate_mode(""), Error);
}

TEST_CASE("top_k_by_confidence: descending, ties by lower index", "[geometry][gating]") {
  VectorX<double> c(8);
  c << 0.5, 0.9, 0.5, 0.9, 0.1, 0.5, 1.0, 0.9;
  CHECK(top_k_by_confidence<double>(c, 1) == std::vector<Eigen::Index>{6});
  CHECK(top_k_by_confidence<double>(c, 4) == std::vector<Eigen::Index>{6, 1, 3, 7});
  CHECK(top_k_by_confidence<double>(c, 6) == std::vector<Eigen::Index>{6, 1, 3, 7, 0, 2});
  CHECK(top_k_by_confidence<double>(c, 100) == std::vector<Eigen::Index>{6, 1, 3, 7, 0, 2, 5, 4});
  CHECK(top_k_by_confidence<double>(c, 0).empty());
  // All equal: the first k indices, in order.
  const VectorX<double> flat = VectorX<double>::Constant(50, 0.25);
  const auto idx = top_k_by_confidence<double>(flat, 10);
  for (std::size_t k = 0; k < 10; ++k) CHECK(idx[k] == static_cast<Eigen::Index>(k));
}

TEST_CASE("gate_reference: F from the top-k matches weighted by confidence", "[geometry][gating]") {
  // 40 good matches with high confidence, 20 bad ones with low confidence.
  const Camerad a = carm_pose(30, 20).camera(), b = carm_pose(-30, -15).camera();
  const Eigen::Matrix3d F_true = fundamental_from_cameras(a, b);
  auto scene = gimm_test::make_pair_scene(a, b, 60, 8);
  VectorX<double> c(60);
  Rng rng(9);
  for (Eigen::Index i = 0; i < 60; ++i) {
    if (i % 3 == 2) {  // bad
      scene.x_b.col(i) = Eigen::Vector2d(rng.uniform(0, 511), rng.uniform(0, 511));
      c(i) = rng.uniform(0.05, 0.2);
    } else {
      c(i) = rng.uniform(0.5, 1.0);
    }
  }
  GateOptions o;
  o.top_k = 40;
  o.min_matches = 32;

  SECTION("reproduces the reference: 8-point on the top-k, weights = confidence, then gate") {
    const auto r = gate_reference<double>(scene.x_a, scene.x_b, c, o);
    REQUIRE(r.F);
    const auto idx = top_k_by_confidence<double>(c, 40);
    Points2<double> ka(2, 40), kb(2, 40);
    VectorX<double> kw(40);
    for (std::size_t k = 0; k < 40; ++k) {
      ka.col(k) = scene.x_a.col(idx[k]);
      kb.col(k) = scene.x_b.col(idx[k]);
      kw(k) = c(idx[k]);
    }
    const auto F_ref = fundamental_8pt<double>(ka, kb, kw);
    REQUIRE(F_ref);
    CHECK(*r.F == *F_ref);
    CHECK(*fundamental_from_matches<double>(scene.x_a, scene.x_b, c, o) == *F_ref);
    const auto expected = gate_with_fundamental<double>(*F_ref, scene.x_a, scene.x_b, c, o);
    CHECK(r.confidence == expected.confidence);
    CHECK(r.keep == expected.keep);
    CHECK(r.distance_sq == expected.distance_sq);
    // The top 40 are exactly the good matches, so F is the true one and the bad are dropped.
    CHECK((*r.F - F_true).norm() < 1e-6);
    for (Eigen::Index i = 0; i < 60; ++i) {
      CAPTURE(i);
      const bool bad = i % 3 == 2;
      if (bad &&
          symmetric_epipolar_distance_sq<double>(F_true, scene.x_a.col(i), scene.x_b.col(i)) > 5) {
        CHECK(r.keep[static_cast<std::size_t>(i)] == 0);
        CHECK(r.confidence(i) == 0);
      }
      if (!bad) {
        CHECK(r.keep[static_cast<std::size_t>(i)] == 1);
        CHECK(r.confidence(i) == c(i));
      }
    }
  }
  SECTION("all matches in the estimate let the bad ones in") {
    o.top_k = 60;
    const auto r = gate_reference<double>(scene.x_a, scene.x_b, c, o);
    REQUIRE(r.F);
    CHECK((*r.F - F_true).norm() > 1e-3);
  }
  SECTION("fewer than min_matches: no gating") {
    o.min_matches = 61;
    const auto r = gate_reference<double>(scene.x_a, scene.x_b, c, o);
    CHECK_FALSE(r.F);
    CHECK(r.confidence == c);
    CHECK(r.keep == std::vector<char>(60, 1));
    CHECK(r.distance_sq.size() == 0);
    CHECK_FALSE(fundamental_from_matches<double>(scene.x_a, scene.x_b, c, o));
  }
  SECTION("exactly min_matches: gated") {
    o.min_matches = 60;
    CHECK(gate_reference<double>(scene.x_a, scene.x_b, c, o).F);
  }
  SECTION("mode none: unchanged") {
    o.mode = GateMode::none;
    const auto r = gate_reference<double>(scene.x_a, scene.x_b, c, o);
    CHECK_FALSE(r.F);
    CHECK(r.confidence == c);
    CHECK(r.keep == std::vector<char>(60, 1));
  }
  SECTION("degenerate estimate: unchanged") {
    Points2<double> same = scene.x_a;
    same.colwise() = Eigen::Vector2d(100, 100);
    const auto r = gate_reference<double>(same, scene.x_b, c, o);
    CHECK_FALSE(r.F);
    CHECK(r.confidence == c);
    CHECK(r.keep == std::vector<char>(60, 1));
  }
  SECTION("soft and logit gate with the estimated F") {
    for (GateMode mode : {GateMode::soft, GateMode::logit}) {
      o.mode = mode;
      const auto r = gate_reference<double>(scene.x_a, scene.x_b, c, o);
      REQUIRE(r.F);
      for (Eigen::Index i = 0; i < 60; ++i)
        CHECK(r.confidence(i) == Approx(c(i) * gate_factor(mode, r.distance_sq(i), o)));
    }
  }
}

}  // namespace gating_test
