// The clinical view protocol: classes, ranges, jitter, pair counts, determinism.
#include <catch2/catch.hpp>
#include <set>

#include "gimm/labels/view_protocol.hpp"

using namespace gimm;

TEST_CASE("View classes: 11 classes, ids 1..11, 4 RCA + 7 LCA", "[labels][views]") {
  CHECK(routine_views().size() == 11);
  for (int id = 1; id <= 11; ++id) CHECK(view_class(id).id == id);
  CHECK(views_of(CoronarySystem::RCA).size() == 4);
  CHECK(views_of(CoronarySystem::LCA).size() == 7);
  CHECK(std::string(view_class(9).name) == "LAO Caudal");
  CHECK(view_class(9).primary.lo == 35);
  CHECK(view_class(9).secondary.hi == -20);
  CHECK_THROWS_WITH(view_class(0), Catch::Contains("1..11"));
  CHECK_THROWS_WITH(view_class(12), Catch::Contains("got 12"));
}

TEST_CASE("View sampling: within the range widened by 5 degrees, and it uses the width",
          "[labels][protocol]") {
  Rng rng(1);
  for (const auto& v : routine_views()) {
    double lo = 1e9, hi = -1e9;
    for (int n = 0; n < 2000; ++n) {
      const SampledView s = sample_view(v, rng);
      REQUIRE(s.view_class == v.id);
      REQUIRE(s.primary_deg >= v.primary.lo - 5);
      REQUIRE(s.primary_deg <= v.primary.hi + 5);
      REQUIRE(s.secondary_deg >= v.secondary.lo - 5);
      REQUIRE(s.secondary_deg <= v.secondary.hi + 5);
      lo = std::min(lo, s.primary_deg);
      hi = std::max(hi, s.primary_deg);
    }
    CHECK(lo < v.primary.lo - 4.5);  // the jitter is really applied
    CHECK(hi > v.primary.hi + 4.5);
  }
}

TEST_CASE("View plans: 6 RCA + 21 LCA pairs; 11 renders shared, 54 per pair",
          "[labels][protocol]") {
  Rng rng(7);
  const ViewPlan rca = plan_views(CoronarySystem::RCA, ViewMode::shared, rng);
  const ViewPlan lca = plan_views(CoronarySystem::LCA, ViewMode::shared, rng);
  CHECK(rca.pairs.size() == 6);
  CHECK(lca.pairs.size() == 21);
  CHECK(rca.views.size() + lca.views.size() == 11);
  const ViewPlan rca_pp = plan_views(CoronarySystem::RCA, ViewMode::per_pair, rng);
  const ViewPlan lca_pp = plan_views(CoronarySystem::LCA, ViewMode::per_pair, rng);
  CHECK(rca_pp.views.size() + lca_pp.views.size() == 54);
  std::set<std::pair<int, int>> class_pairs;
  for (const auto& p : lca_pp.pairs) {
    const int a = lca_pp.views[p.a].view_class, b = lca_pp.views[p.b].view_class;
    CHECK(a < b);
    CHECK(view_class(a).system == CoronarySystem::LCA);
    class_pairs.insert({a, b});
  }
  CHECK(class_pairs.size() == 21);
  // Same seed, same plan.
  Rng r1(99), r2(99);
  const ViewPlan p1 = plan_views(CoronarySystem::LCA, ViewMode::per_pair, r1);
  const ViewPlan p2 = plan_views(CoronarySystem::LCA, ViewMode::per_pair, r2);
  for (std::size_t v = 0; v < p1.views.size(); ++v)
    CHECK(p1.views[v].primary_deg == p2.views[v].primary_deg);
  CHECK_THROWS_WITH(parse_view_mode("both"), Catch::Contains("'both'"));
}
