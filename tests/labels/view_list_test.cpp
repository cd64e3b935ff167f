// Views placed on purpose (gimm-views/1): parsing, classes from the angles, shared renders,
// and every bad input refused with the field and value named.
#include <catch2/catch.hpp>

#include "gimm/labels/view_list.hpp"

using namespace gimm;
using nlohmann::json;

namespace {

json pose(double primary, double secondary) {
  return {{"primary", primary}, {"secondary", secondary}};
}

json list_of(json pairs) {
  return {{"format", "gimm-views/1"}, {"pairs", std::move(pairs)}};
}

}  // namespace

TEST_CASE("View list: classes from the angles, poses shared, file order kept",
          "[labels][view_list]") {
  const json doc = list_of({{{"system", "LCA"}, {"a", pose(45, 22)}, {"b", pose(50, 22)}},
                            {{"system", "LCA"}, {"a", pose(45, 22)}, {"b", pose(-30, 20)}},
                            {{"system", "RCA"}, {"a", pose(50, 0)}, {"b", pose(-30, 5)}}});
  const auto pairs = view_list_from_json(doc, "test");
  REQUIRE(pairs.size() == 3);
  CHECK(pairs[0].a.view_class == 8);   // LCA LAO Cranial: inside its ranges
  CHECK(pairs[1].b.view_class == 10);  // LCA RAO Cranial
  CHECK(pairs[2].a.view_class == 2);   // RCA LAO
  CHECK(pairs[2].b.view_class == 4);   // RCA RAO
  // The class is the system's own: LAO 45 / cranial 22 is LCA class 8 but RCA class 3.
  const auto rca = view_list_from_json(
      list_of({{{"system", "RCA"}, {"a", pose(45, 22)}, {"b", pose(50, 0)}}}), "test");
  CHECK(rca[0].a.view_class == 3);

  const ViewPlan lca = plan_listed_views(CoronarySystem::LCA, pairs);
  REQUIRE(lca.views.size() == 3);  // (45, 22) rendered once for both of its pairs
  REQUIRE(lca.pairs.size() == 2);
  CHECK(lca.pairs[0].a == 0);
  CHECK(lca.pairs[0].b == 1);
  CHECK(lca.pairs[1].a == 0);
  CHECK(lca.pairs[1].b == 2);
  CHECK(lca.views[1].primary_deg == 50);
  const ViewPlan rca_plan = plan_listed_views(CoronarySystem::RCA, pairs);
  CHECK(rca_plan.views.size() == 2);
  CHECK(rca_plan.pairs.size() == 1);

  // The manifest's record reads back as the same list.
  const auto again = view_list_from_json(view_list_to_json(pairs), "again");
  REQUIRE(again.size() == pairs.size());
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    CHECK(again[i].system == pairs[i].system);
    CHECK(again[i].b.primary_deg == pairs[i].b.primary_deg);
    CHECK(again[i].b.view_class == pairs[i].b.view_class);
  }
}

TEST_CASE("View list: a system the list does not name has no views", "[labels][view_list]") {
  const auto pairs = view_list_from_json(
      list_of({{{"system", "LCA"}, {"a", pose(0, 0)}, {"b", pose(5, 0)}}}), "test");
  const ViewPlan rca = plan_listed_views(CoronarySystem::RCA, pairs);
  CHECK(rca.views.empty());
  CHECK(rca.pairs.empty());
  // 5 degrees in primary at secondary 0 is a separation of exactly 5 degrees.
  CHECK(view_angle_between(0, 0, 5, 0) == Approx(5).margin(1e-9));
}

TEST_CASE("View list: bad input is refused naming the field and value", "[labels][view_list]") {
  const json good = {{"system", "LCA"}, {"a", pose(0, 0)}, {"b", pose(30, 0)}};
  const auto fails = [](const json& doc, const std::string& text) {
    CHECK_THROWS_AS(view_list_from_json(doc, "list.json"), FormatError);
    CHECK_THROWS_WITH(view_list_from_json(doc, "list.json"), Catch::Contains(text));
  };
  fails(json::array(), "must be a JSON object");
  fails({{"format", "gimm-views/2"}, {"pairs", {good}}}, "'gimm-views/2'");
  fails({{"pairs", {good}}}, "missing field 'format'");
  fails(list_of(json::array()), "non-empty array");
  fails(list_of(json{{"system", "LCA"}}), "non-empty array");
  fails({{"format", "gimm-views/1"}, {"pairs", {good}}, {"pair", 1}}, "unknown field 'pair'");
  fails({{"format", "gimm-views/1"}, {"pairs", {good}}, {"note", 5}}, "'note' is free text");

  json bad = good;
  bad["system"] = "LAD";
  fails(list_of({bad}), "pairs[0]: 'system' must be RCA or LCA, got 'LAD'");
  bad = good;
  bad.erase("b");
  fails(list_of({good, bad}), "pairs[1]: missing field 'b'");
  bad = good;
  bad["a"] = {{"primary", 0}, {"secundary", 10}};
  fails(list_of({bad}), "pairs[0].a: unknown field 'secundary'");
  bad = good;
  bad["a"] = {{"primary", "LAO"}, {"secondary", 0}};
  fails(list_of({bad}), "'primary' must be a finite number, got \"LAO\"");
  bad = good;
  bad["b"] = pose(0, 90);
  fails(list_of({bad}), "pairs[0].b: 'secondary' must be in (-90, 90) degrees, got 90");
  bad = good;
  bad["b"] = pose(-181, 0);
  fails(list_of({bad}), "'primary' must be in [-180, 180] degrees, got -181");
  bad = good;
  bad["b"] = pose(0.5, 0);
  fails(list_of({bad}), "0.5 degrees apart");
  // The documented minimum itself is a pair: 30 and 31 degrees came out 0.99999... apart.
  json one_degree = good;
  one_degree["a"] = pose(30, 0);
  one_degree["b"] = pose(31, 0);
  CHECK_NOTHROW(view_list_from_json(list_of({one_degree}), "list.json"));
  bad = good;
  bad["a"] = 30;
  fails(list_of({bad}), "a pose must be an object");
  // The same pair twice, in either order, is refused; in the other system it is another pair.
  json swapped = good;
  std::swap(swapped["a"], swapped["b"]);
  fails(list_of({good, good}), "pairs[1]: the same pair as pairs[0]");
  fails(list_of({good, swapped}), "pairs[1]: the same pair as pairs[0]");
  json other_system = good;
  other_system["system"] = "RCA";
  CHECK(view_list_from_json(list_of({good, other_system}), "test").size() == 2);
  CHECK(view_list_from_json({{"format", "gimm-views/1"}, {"note", "sweep"}, {"pairs", {good}}},
                            "test")
            .size() == 1);
  // The file reader names the file.
  CHECK_THROWS_WITH(read_view_list("/nonexistent/views.json"),
                    Catch::Contains("/nonexistent/views.json"));
}
