// A user's own sparse truth scored with the protocol (metrics/user_truth.hpp), and the 3D error
// of triangulated points against centerlines (metrics/tree_error.hpp).
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>

#include "gimm/io/files.hpp"
#include "gimm/metrics/protocol.hpp"
#include "gimm/metrics/report.hpp"
#include "gimm/metrics/summary.hpp"
#include "gimm/metrics/tree_error.hpp"
#include "gimm/metrics/user_truth.hpp"

namespace fs = std::filesystem;

namespace {
fs::path truth_file(const std::string& name, const std::string& text) {
  fs::create_directories(fs::path(GIMM_TEST_TMP) / "user_truth");
  const fs::path p = fs::path(GIMM_TEST_TMP) / "user_truth" / name;
  gimm::write_file_atomic(p, text);
  return p;
}
}  // namespace

TEST_CASE("Own truth: matches near a truth point are scored, the rest are not", "[metrics]") {
  const fs::path path =
      truth_file("pair.json", R"({"format": "gimm-truth/1", "points_a": [[10, 10], [40, 20]],
                      "points_b": [[12, 30], [50, 25]], "world_mm": [[0, 0, 0], [3, 4, 0]]})");
  const gimm::PairTruth truth = gimm::read_user_truth(path, 3.0);
  CHECK(truth.id == "pair");
  gimm::PairMatches m;
  m.add({10, 10}, {12, 30}, 0.9);  // exact
  m.add({41, 20}, {50, 29}, 0.8);  // A within 1 px of truth 2; B 4 px off
  m.add({90, 90}, {5, 5}, 0.7);    // far from every truth point, in both views
  const gimm::PairScore score = gimm::score_pair(truth, m);
  REQUIRE(score.ranked.size() == 3);
  CHECK(score.ranked[0].ab.scored);
  CHECK(score.ranked[0].ab.error_px == 0);
  CHECK(score.ranked[0].ab.error_mm == 0);
  CHECK(score.ranked[1].ab.error_px == Approx(4));
  CHECK_FALSE(score.ranked[2].ab.scored);
  CHECK_FALSE(score.ranked[2].ba.scored);
  CHECK(std::isnan(score.ranked[0].epipolar_px));  // no F in the file: no epipolar column
  const gimm::Summary s = gimm::summarize({score}, 0);
  // Match 1 both ways; match 2 A->B only (its B point is 4 px from B's truth, past the radius).
  CHECK(s.scored == 3);
  CHECK(s.coverage == Approx(3.0 / 6.0));

  // Without world points: no 3D error, and no NaN in the summary's 2D numbers.
  const gimm::PairTruth flat = gimm::read_user_truth(
      truth_file("flat.json", R"({"points_a": [[10, 10]], "points_b": [[12, 30]]})"), 3.0);
  const gimm::Summary f = gimm::summarize({gimm::score_pair(flat, m)}, 0);
  CHECK(f.prec[1] == 1.0);
  CHECK(std::isnan(f.mean_mm));

  CHECK_THROWS_WITH(gimm::read_user_truth(
                        truth_file("short.json", R"({"points_a": [[1, 2]], "points_b": []})"), 3),
                    Catch::Contains("short.json") && Catch::Contains("equally long"));
  CHECK_THROWS_WITH(gimm::read_user_truth(truth_file("world.json", R"({"points_a": [[1, 2]],
          "points_b": [[1, 2]], "world_mm": [[1, 2]]})"),
                                          3),
                    Catch::Contains("world.json") && Catch::Contains("world_mm"));
  CHECK_THROWS_WITH(gimm::read_user_truth(path, 0), Catch::Contains("radius"));
  CHECK_THROWS_WITH(gimm::read_user_truth(path, 1e6), Catch::Contains("radius"));
  // A point off any detector asked for a mask of rows x cols bytes: 1.5 GB at 40000 px, an int
  // overflow at 3e9. Refused by name and value, before any mask is made.
  for (const char* far : {"40000", "3e9", "16384"})
    CHECK_THROWS_WITH(
        gimm::read_user_truth(truth_file("far.json", std::string(R"({"points_a": [[1, 2]],
            "points_b": [[)") + far + ", 5]]}"),
                              3),
        Catch::Contains("far.json") && Catch::Contains("point 0") && Catch::Contains("detector"));
  CHECK(gimm::read_user_truth(truth_file("edge.json", R"({"points_a": [[16383, 2]],
            "points_b": [[1, 2]]})"),
                              1)
            .mask_a->cols() == 16385);
}

TEST_CASE("Tree error: distance to the polylines, not only their vertices", "[metrics]") {
  gimm::CenterlineTree tree;
  gimm::CenterlineBranch b;
  b.points = {{0, 0, 0}, {10, 0, 0}, {10, 10, 0}};
  b.radii = {1, 1, 1};
  tree.branches.push_back(b);
  CHECK(gimm::distance_to_centerlines({5, 2, 0}, tree) == Approx(2));       // mid-segment
  CHECK(gimm::distance_to_centerlines({-3, 4, 0}, tree) == Approx(5));      // past the end
  CHECK(gimm::distance_to_centerlines({10, 5, 1.5}, tree) == Approx(1.5));  // second segment
  CHECK(std::isinf(gimm::distance_to_centerlines({0, 0, 0}, gimm::CenterlineTree{})));
}

TEST_CASE("Eval summary: an earlier run's summary.json is read or refused by key", "[metrics]") {
  const fs::path ok = truth_file("summary.json", R"({"format": "gimm-eval/1", "method": "m",
      "top_k": 20, "pooled": {"pairs": 3, "matches": 40, "prec_3px": 0.75, "mean_px": 2.5,
      "median_mm": null}})");
  const gimm::EvalSummaryFile s = gimm::read_eval_summary(ok);
  CHECK(s.method == "m");
  CHECK(s.top_k == 20);
  CHECK(s.pooled.pairs == 3);
  CHECK(s.pooled.matches == 40);
  CHECK(s.pooled.prec[1] == 0.75);
  CHECK(s.pooled.mean_px == 2.5);
  CHECK(std::isnan(s.pooled.median_mm));
  CHECK(gimm::read_eval_summary(truth_file("unnamed.json", R"({"format": "gimm-eval/1",
      "top_k": 0, "pooled": {}})"),
                                "run1")
            .method == "run1");
  // Before: nlohmann's own errors ("type must be number"), naming neither file nor key.
  for (const auto& [text, word] : std::vector<std::pair<std::string, std::string>>{
           {R"({"format": "gimm-eval/2", "top_k": 1, "pooled": {}})", "gimm-eval/1"},
           {R"({"format": "gimm-eval/1", "top_k": "x", "pooled": {}})", "top_k"},
           {R"({"format": "gimm-eval/1", "top_k": -3, "pooled": {}})", "top_k"},
           {R"({"format": "gimm-eval/1", "top_k": 1, "pooled": 7})", "pooled"},
           {R"({"format": "gimm-eval/1", "top_k": 1, "pooled": {"pairs": "3"}})", "pairs"},
           {R"({"format": "gimm-eval/1", "top_k": 1, "pooled": {"pairs": -3}})", "pairs"},
           {R"({"format": "gimm-eval/1", "top_k": 1, "method": 5, "pooled": {}})", "method"}}) {
    INFO(text);
    const fs::path bad = truth_file("bad_summary.json", text);
    CHECK_THROWS_AS(gimm::read_eval_summary(bad), gimm::FormatError);
    CHECK_THROWS_WITH(gimm::read_eval_summary(bad),
                      Catch::Contains("bad_summary.json") && Catch::Contains(word));
  }
}

TEST_CASE("Own truth: a matches file naming another pair is refused", "[metrics]") {
  gimm::PairTruth truth;
  truth.id = "LCA_00-01";
  gimm::PairMatches m;
  for (const char* agreeing : {"", "LCA_00-01", "phantom-0003/LCA_00-01"}) {
    m.pair = agreeing;
    CHECK_NOTHROW(gimm::check_same_pair(truth, "t.json", m, "m.json"));
  }
  for (const char* other : {"LCA_00-02", "phantom-0003/LCA_00-011", "xLCA_00-01", "LCA_00"}) {
    m.pair = other;
    CHECK_THROWS_WITH(gimm::check_same_pair(truth, "t.json", m, "m.json"),
                      Catch::Contains("m.json holds the matches of pair '" + std::string(other)) &&
                          Catch::Contains("t.json is the truth of pair 'LCA_00-01'"));
  }
}
