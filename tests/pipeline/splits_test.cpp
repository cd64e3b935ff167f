// Patient-level splits: exact 70/15/15 counts, the same whatever the input order, seeded.
#include <catch2/catch.hpp>
#include <map>
#include <string>

#include "gimm/pipeline/patient.hpp"

using namespace gimm;

namespace {
std::vector<PatientSource> patients(int n) {
  std::vector<PatientSource> out(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) out[k].id = "p" + std::to_string(k);
  return out;
}
std::map<std::string, int> counts(const std::vector<PatientSource>& ps) {
  std::map<std::string, int> c;
  for (const auto& p : ps) ++c[p.split];
  return c;
}
}  // namespace

TEST_CASE("Splits have exact proportions; small runs still get val and test", "[pipeline]") {
  DatasetOptions o;
  o.seed = 5;
  struct Want {
    int n, train, val, test;
  };
  for (const Want w : {Want{1000, 700, 150, 150}, Want{20, 14, 3, 3}, Want{7, 5, 1, 1},
                       Want{4, 2, 1, 1}, Want{3, 1, 1, 1}, Want{2, 2, 0, 0}, Want{1, 1, 0, 0}}) {
    auto ps = patients(w.n);
    assign_splits(ps, o);
    auto c = counts(ps);
    INFO("n = " << w.n);
    CHECK(c["train"] == w.train);
    CHECK(c["val"] == w.val);
    CHECK(c["test"] == w.test);
  }
}

TEST_CASE("Splits depend on the seed and the ids, not on their order", "[pipeline]") {
  DatasetOptions o;
  o.seed = 11;
  auto a = patients(40);
  auto b = a;
  std::reverse(b.begin(), b.end());
  assign_splits(a, o);
  assign_splits(b, o);
  std::map<std::string, std::string> by_id;
  for (const auto& p : a) by_id[p.id] = p.split;
  for (const auto& p : b) CHECK(by_id[p.id] == p.split);
  auto c = patients(40);
  o.seed = 12;
  assign_splits(c, o);
  int moved = 0;
  for (const auto& p : c) moved += by_id[p.id] != p.split;
  CHECK(moved > 0);
}

TEST_CASE("Split fractions outside [0, 1] are refused", "[pipeline]") {
  DatasetOptions o;
  o.split_train = 0.9;
  o.split_val = 0.2;
  auto ps = patients(5);
  CHECK_THROWS_WITH(assign_splits(ps, o), Catch::Contains("val 0.2"));
  o.split_train = -0.1;
  o.split_val = 0.1;
  CHECK_THROWS_WITH(assign_splits(ps, o), Catch::Contains("train -0.1"));
}
