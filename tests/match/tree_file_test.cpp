// gimm-tree/1 (match/tree_file.hpp): a file written by hand is read to the numbers in it, the
// writer's output reads back, and malformed files are refused naming the file and the key.
#include <catch2/catch.hpp>
#include <filesystem>

#include "gimm/io/files.hpp"
#include "gimm/match/tree_file.hpp"

namespace fs = std::filesystem;

namespace {
fs::path tree_text(const std::string& name, const std::string& text) {
  const fs::path dir = fs::path(GIMM_TEST_TMP) / "tree_file";
  fs::create_directories(dir);
  gimm::write_file_atomic(dir / name, text);
  return dir / name;
}
}  // namespace

TEST_CASE("Tree file: a hand-written file reads to its numbers", "[match][tree_file]") {
  const gimm::TreeFile t = gimm::read_tree_file(tree_text("hand.json", R"({
    "format": "gimm-tree/1", "dropped_degenerate": 2, "dropped_reprojection": 5,
    "points": [
      {"a": [10.5, 20], "b": [30, 40.25], "world_mm": [1, -2, 3.5], "confidence": 0.75,
       "reprojection_px": [0.5, 1.5]},
      {"a": [0, 0], "b": [1, 1], "world_mm": [0, 0, 0], "branch": 4, "consistent": false}]})"));
  REQUIRE(t.points.size() == 2);
  CHECK(t.points[0].a == Eigen::Vector2d(10.5, 20));
  CHECK(t.points[0].b == Eigen::Vector2d(30, 40.25));
  CHECK(t.points[0].world == Eigen::Vector3d(1, -2, 3.5));
  CHECK(t.points[0].confidence == 0.75);
  CHECK(*t.points[0].reprojection_px == Eigen::Vector2d(0.5, 1.5));
  CHECK_FALSE(t.points[0].branch);
  CHECK(*t.points[1].branch == 4);
  CHECK(*t.points[1].consistent == false);
  CHECK(t.points[1].confidence == 0);
  CHECK(*t.dropped_degenerate == 2);
  CHECK(*t.dropped_reprojection == 5);

  // The writer's output reads back the same.
  const fs::path again = fs::path(GIMM_TEST_TMP) / "tree_file" / "again.json";
  gimm::write_tree_file(again, t);
  const gimm::TreeFile u = gimm::read_tree_file(again);
  REQUIRE(u.points.size() == 2);
  CHECK(u.points[0].world == t.points[0].world);
  CHECK(*u.points[0].reprojection_px == *t.points[0].reprojection_px);
  CHECK(*u.points[1].branch == 4);
  CHECK(*u.dropped_reprojection == 5);
  CHECK(gimm::read_json_file(again)["format"] == "gimm-tree/1");
}

TEST_CASE("Tree file: malformed files are refused by file and key", "[match][tree_file]") {
  const auto refused = [](const std::string& name, const std::string& text,
                          const std::string& word) {
    INFO(text);
    const fs::path p = tree_text(name, text);
    CHECK_THROWS_AS(gimm::read_tree_file(p), gimm::FormatError);
    CHECK_THROWS_WITH(gimm::read_tree_file(p),
                      Catch::Contains(p.string()) && Catch::Contains(word));
  };
  refused("none.json", R"({"points": []})", "gimm-tree/1");
  refused("v2.json", R"({"format": "gimm-tree/2", "points": []})", "gimm-tree/2");
  refused("array.json", R"([1, 2])", "format");
  refused("points.json", R"({"format": "gimm-tree/1", "points": 3})", "'points'");
  refused("short.json", R"({"format": "gimm-tree/1", "points": [{"a": [1], "b": [1, 2],
          "world_mm": [0, 0, 0]}]})",
          "points[0].a");
  refused("nan.json", R"({"format": "gimm-tree/1", "points": [{"a": [1, 2], "b": [1, 2],
          "world_mm": [0, "x", 0]}]})",
          "points[0].world_mm");
  refused("huge.json", R"({"format": "gimm-tree/1", "points": [{"a": [1, 2], "b": [1, 2],
          "world_mm": [0, 1e999, 0]}]})",
          "");
  refused("branch.json", R"({"format": "gimm-tree/1", "points": [{"a": [1, 2], "b": [1, 2],
          "world_mm": [0, 0, 0], "branch": 18446744073709551615}]})",
          "branch");
  refused("count.json", R"({"format": "gimm-tree/1", "points": [], "dropped_degenerate": -1})",
          "dropped_degenerate");
}
