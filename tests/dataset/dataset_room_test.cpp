// The dataset room: one layout, one reader rule for dense columns (by name, checked against
// dense_fields), the manifest's format, and merging shard manifests.
#include <catch2/catch.hpp>
#include <filesystem>

#include "gimm/dataset/layout.hpp"
#include "gimm/dataset/reader.hpp"
#include "gimm/dataset/run.hpp"
#include "gimm/dataset/writer.hpp"
#include "gimm/pipeline/dataset_run.hpp"  // merge_dataset: the one merge

namespace fs = std::filesystem;
using nlohmann::json;

namespace {
fs::path fresh(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("gimm_dataset_room_" + name);
  fs::remove_all(p);
  fs::create_directories(p);
  return p;
}

json pair_with(json fields, json dense) {
  return {{"view_a", "LCA_00"},
          {"view_b", "LCA_01"},
          {"view_class_a", 1},
          {"view_class_b", 2},
          {"F", {{0, 0, 0}, {0, 0, -1}, {0, 1, 0}}},
          {"dense_fields", fields},
          {"dense", dense},
          {"sparse", json::array()}};
}
}  // namespace

TEST_CASE("Dataset layout: every path from one place", "[dataset]") {
  const gimm::DatasetLayout l("/d");
  CHECK(l.manifest() == fs::path("/d/manifest.json"));
  CHECK(l.manifest({1, 3}) == fs::path("/d/manifest.shard-1-of-3.json"));
  CHECK(l.split_list("val") == fs::path("/d/splits/val.txt"));
  CHECK(l.view_image("p", "RCA_02") == fs::path("/d/patients/p/views/RCA_02.png"));
  CHECK(l.view_mask("p", "RCA_02") == fs::path("/d/patients/p/views/RCA_02.mask.png"));
  CHECK(l.view_camera("p", "RCA_02") == fs::path("/d/patients/p/views/RCA_02.camera.json"));
  CHECK(l.pair_labels("p/RCA_00-02") == fs::path("/d/patients/p/pairs/RCA_00-02.json"));
  CHECK(l.done_record("p") == fs::path("/d/patients/p/done.json"));
  CHECK(gimm::view_name("LCA", 3) == "LCA_03");
  CHECK(gimm::pair_name("LCA", 3, 10) == "LCA_03-10");
  CHECK_THROWS_WITH(gimm::split_pair_id("nopatient"), Catch::Contains("'nopatient'"));
  CHECK_THROWS_WITH(gimm::split_pair_id("a/b/c"), Catch::Contains("'a/b/c'"));
  CHECK_THROWS_WITH(gimm::split_pair_id("../x"), Catch::Contains("'../x'"));
  CHECK_THROWS_WITH(gimm::split_pair_id("p/.."), Catch::Contains("'p/..'"));
}

TEST_CASE("Dataset reader: dense columns are found by name", "[dataset]") {
  // The columns in another order than the writer's, with an extra one: read by name.
  const json fields = {"x_mm", "y_mm", "z_mm", "extra", "u_b", "v_b", "u_a", "v_a", "point"};
  const json j = pair_with(fields, {{5, 6, 7, 99, 3, 4, 1, 2, 11}});
  const gimm::PairTruth t = gimm::pair_truth_from_json(j, "p/LCA_00-01", "here.json");
  REQUIRE(t.dense.size() == 1);
  CHECK(t.dense[0].a == Eigen::Vector2d(1, 2));
  CHECK(t.dense[0].b == Eigen::Vector2d(3, 4));
  CHECK(t.dense[0].world == Eigen::Vector3d(5, 6, 7));
  CHECK(t.dense[0].index == 11);

  CHECK_THROWS_WITH(
      gimm::pair_truth_from_json(pair_with({"u_a", "v_a"}, json::array()), "p/x", "here.json"),
      Catch::Contains("here.json") && Catch::Contains("no 'u_b'"));
  CHECK_THROWS_WITH(gimm::dense_labels_from_json(pair_with(fields, {{1, 2, 3}}), "here.json"),
                    Catch::Contains("dense row 0 must hold 9 numbers"));
  CHECK_THROWS_WITH(
      gimm::dense_labels_from_json(pair_with(fields, {{5, 6, 7, 0, 3, 4, "x", 2, 1}}), "h.json"),
      Catch::Contains("'u_a' must be a finite number"));
  // Integers are checked before they are converted (libFuzzer: view_class_a 49e9 was converted
  // to int, which is undefined).
  for (const json& bad : {json(49e9), json(2.5), json(12), json(-1), json("1"),
                          json(std::uint64_t(18446744073709551615ull))}) {
    json j2 = pair_with(fields, json::array());
    j2["view_class_a"] = bad;
    CHECK_THROWS_WITH(gimm::pair_truth_from_json(j2, "p/x", "here.json"),
                      Catch::Contains("here.json") && Catch::Contains("'view_class_a'") &&
                          Catch::Contains("view class id 1..11") && Catch::Contains(bad.dump()));
  }
  json unknown = pair_with(fields, json::array());
  unknown.erase("view_class_b");
  unknown["view_class_a"] = 0;
  const gimm::PairTruth u = gimm::pair_truth_from_json(unknown, "p/x", "here.json");
  CHECK((u.view_class_a == 0 && u.view_class_b == 0));
  CHECK_THROWS_WITH(gimm::dense_labels_from_json(
                        pair_with(fields, {{5, 6, 7, 0, 3, 4, 1, 2, 4294967296LL}}), "h.json"),
                    Catch::Contains("'point' must be an integer in int's range, got 4294967296"));
  json no_fields = pair_with(fields, json::array());
  no_fields.erase("dense_fields");
  CHECK_THROWS_WITH(gimm::dense_labels_from_json(no_fields, "h.json"),
                    Catch::Contains("h.json") && Catch::Contains("dense_fields"));
}

TEST_CASE("Dataset reader: the manifest's format is checked", "[dataset]") {
  const fs::path root = fresh("format");
  fs::create_directories(root / "patients");
  gimm::write_json_file(root / "manifest.json", {{"patients", json::array()}});
  CHECK_THROWS_WITH(gimm::DatasetReader(root), Catch::Contains("no 'format'"));
  gimm::write_json_file(root / "manifest.json",
                        {{"format", "gimm-dataset/3"}, {"patients", json::array()}});
  CHECK_THROWS_WITH(gimm::DatasetReader(root), Catch::Contains("\"gimm-dataset/3\" is not"));
  gimm::write_json_file(
      root / "manifest.json",
      {{"format", "gimm-dataset/2"}, {"images", {"drr"}}, {"patients", json::array()}});
  CHECK(gimm::DatasetReader(root).pair_ids().empty());
  CHECK(std::string(gimm::kDatasetFormat) == "gimm-dataset/2");
}

TEST_CASE("Dataset reader: the images of /2 by its list, of /1 by its parameters", "[dataset]") {
  using Images = std::vector<std::string>;
  const Images drr{"drr"}, formed{"drr", "formed", "field"};
  // /1 (before the list): formed images exactly where the parameters record a formation stage.
  CHECK(gimm::dataset_images_of({{"format", "gimm-dataset/1"}, {"parameters", {{"seed", 1}}}},
                                "m") == drr);
  CHECK(gimm::dataset_images_of(
            {{"format", "gimm-dataset/1"}, {"parameters", {{"formation", {{"bits", 8}}}}}}, "m") ==
        formed);
  CHECK(gimm::dataset_images_of({{"format", "gimm-dataset/1"}}, "m") == drr);
  // /2: the list, checked.
  CHECK(gimm::dataset_images_of({{"format", "gimm-dataset/2"}, {"images", formed}}, "m") == formed);
  CHECK_THROWS_WITH(gimm::dataset_images_of({{"format", "gimm-dataset/2"}}, "m.json"),
                    Catch::Contains("m.json: no 'images' list"));
  CHECK_THROWS_WITH(
      gimm::dataset_images_of({{"format", "gimm-dataset/2"}, {"images", {"drr", "xray"}}}, "m"),
      Catch::Contains("'images' holds \"xray\""));
  // What the writer lists, and a reader of it.
  CHECK(gimm::dataset_images(true) == json(formed));
  CHECK(gimm::dataset_images(false) == json(drr));
  const fs::path root = fresh("images");
  fs::create_directories(root / "patients");
  gimm::write_json_file(root / "manifest.json", {{"format", gimm::kDatasetFormat},
                                                 {"images", gimm::dataset_images(true)},
                                                 {"patients", json::array()}});
  CHECK(gimm::DatasetReader(root).has_formed_views());
  gimm::write_json_file(
      root / "manifest.json",
      {{"format", "gimm-dataset/1"}, {"parameters", {{"seed", 2}}}, {"patients", json::array()}});
  CHECK_FALSE(gimm::DatasetReader(root).has_formed_views());
}

TEST_CASE("Dataset reader: a listed patient must be there, under patients/", "[dataset]") {
  const fs::path root = fresh("listed");
  fs::create_directories(root / "patients" / "p1");
  gimm::write_json_file(root / "patients" / "p1" / "done.json", {{"id", "p1"}});
  const std::string manifest = (root / "manifest.json").string();
  auto with = [&](json ids) {
    json patients = json::array();
    for (const auto& id : ids) patients.push_back({{"id", id}, {"status", "ok"}});
    gimm::write_json_file(root / "manifest.json",
                          {{"format", gimm::kDatasetFormat}, {"patients", patients}});
    return gimm::DatasetReader(root);
  };
  CHECK(with({"p1"}).patients() == std::vector<std::string>{"p1"});
  // Silently skipped before: a dataset with a hole scored as if whole.
  CHECK_THROWS_AS(with({"p1", "p2"}).patients(), gimm::FormatError);
  CHECK_THROWS_WITH(with({"p1", "p2"}).patients(), Catch::Contains(manifest) &&
                                                       Catch::Contains("'p2'") &&
                                                       Catch::Contains("missing"));
  // Ids that leave patients/ are refused by name, whatever the folders hold.
  for (const char* bad : {"../../../etc", "..", ".", "", "a/b", "a\\b"})
    CHECK_THROWS_WITH(with({bad}).patients(), Catch::Contains("'" + std::string(bad) + "'") &&
                                                  Catch::Contains("not a folder name"));
  // A failed patient needs no folder.
  gimm::write_json_file(
      root / "manifest.json",
      {{"format", gimm::kDatasetFormat},
       {"patients", {{{"id", "p1"}, {"status", "ok"}}, {{"id", "gone"}, {"status", "failed"}}}}});
  CHECK(gimm::DatasetReader(root).patients() == std::vector<std::string>{"p1"});
}

TEST_CASE("Dataset reader: wrong JSON types and huge numbers name the file and the key",
          "[dataset]") {
  const fs::path root = fresh("types");
  fs::create_directories(root / "patients");
  const std::string manifest = (root / "manifest.json").string();
  // Raw nlohmann messages before ("cannot use value() with number"), naming neither.
  gimm::write_json_file(root / "manifest.json",
                        {{"format", gimm::kDatasetFormat}, {"patients", 7}});
  CHECK_THROWS_WITH(gimm::DatasetReader(root).patients(),
                    Catch::Contains(manifest) && Catch::Contains("'patients' must be an array") &&
                        Catch::Contains("7"));
  gimm::write_json_file(root / "manifest.json",
                        {{"format", gimm::kDatasetFormat}, {"patients", {{{"id", 3}}}}});
  CHECK_THROWS_WITH(gimm::DatasetReader(root).patients(),
                    Catch::Contains(manifest) && Catch::Contains("'patients'[0]"));
  // A number beyond double range is nlohmann's out_of_range, not a parse_error: it escaped.
  gimm::write_file_atomic(root / "manifest.json", std::string("{\"format\": 1e999}"));
  CHECK_THROWS_AS(gimm::DatasetReader(root), gimm::FormatError);
  CHECK_THROWS_WITH(gimm::DatasetReader(root),
                    Catch::Contains(manifest) && Catch::Contains("1e999"));
}

TEST_CASE("Dataset reader: a pair file's views are names, its F no zero matrix", "[dataset]") {
  using Catch::Contains;
  const json F = {{0, 0, 0}, {0, 0, -1}, {0, 1, 0}};
  json pair = {{"view_a", "LCA_00"}, {"view_b", "LCA_01"}, {"F", F}, {"dense", json::array()}};
  json bad = pair;
  bad["view_a"] = "../../../x";  // read views/../../../x.mask.png before
  CHECK_THROWS_WITH(gimm::pair_truth_from_json(bad, "p/LCA_00-01", "pair.json"),
                    Contains("pair.json") && Contains("view_a '../../../x'"));
  bad = pair;
  bad["F"] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};  // turned every epipolar figure into null
  CHECK_THROWS_AS(gimm::pair_truth_from_json(bad, "p/LCA_00-01", "pair.json"), gimm::FormatError);
  CHECK_THROWS_WITH(gimm::pair_truth_from_json(bad, "p/LCA_00-01", "pair.json"),
                    Contains("pair.json") && Contains("'F' is all zeros"));
}

TEST_CASE("Dataset merge: shards of one run only", "[dataset]") {
  const fs::path root = fresh("merge");
  const gimm::DatasetWriter writer(root);
  const auto shard_manifest = [&](int index, int count, const std::string& id) {
    writer.write_manifest({{"format", gimm::kDatasetFormat},
                           {"parameters", {{"seed", 0}}},
                           {"input", {{"phantom", 3}}},
                           {"shard", {{"index", index}, {"count", count}}},
                           {"patients", {{{"id", id}, {"status", "ok"}, {"split", "train"}}}}},
                          {index, count});
  };
  shard_manifest(0, 2, "a");
  shard_manifest(1, 2, "b");
  shard_manifest(2, 3, "c");  // stale, of another sharding: would list a patient twice
  CHECK_THROWS_WITH(gimm::merge_dataset(root, ""), Catch::Contains("a shard of 3") &&
                                                       Catch::Contains("a shard of") &&
                                                       Catch::Contains("another sharding"));
  CHECK(fs::exists(root / "manifest.shard-0-of-2.json"));  // nothing removed on failure
  CHECK_FALSE(fs::exists(root / "manifest.json"));
  fs::remove(root / "manifest.shard-2-of-3.json");
  // A temporary of a killed shard writer is not a shard.
  gimm::write_file_atomic(root / "x.txt", std::string("x"));
  fs::rename(root / "x.txt", root / "manifest.shard-1-of-2.json.tmp.host.1");
  const gimm::MergedShards merged = gimm::merge_dataset(root, "");
  CHECK(merged.shards == 2);
  CHECK(merged.manifest.at("patients").size() == 2);
  CHECK_FALSE(merged.manifest.contains("shard"));
  CHECK(gimm::read_json_file(root / "manifest.json") == merged.manifest);
  const auto split = gimm::read_file_bytes(root / "splits" / "train.txt");
  CHECK(std::string(split.begin(), split.end()) == "a\nb\n");
  CHECK_FALSE(fs::exists(root / "manifest.shard-0-of-2.json"));
}

TEST_CASE("Dataset merge: shards that disagree on their patients are refused", "[dataset]") {
  using Catch::Contains;
  const fs::path root = fresh("merge_bad");
  const gimm::DatasetWriter writer(root);
  const auto shard = [&](int index, nlohmann::json patients) {
    writer.write_manifest({{"format", gimm::kDatasetFormat},
                           {"parameters", {{"seed", 0}}},
                           {"input", {{"phantom", 2}}},
                           {"shard", {{"index", index}, {"count", 2}}},
                           {"patients", std::move(patients)}},
                          {index, 2});
  };
  const auto ok = [](const std::string& id, const std::string& split = "train") {
    return nlohmann::json{{"id", id}, {"status", "ok"}, {"split", split}};
  };
  // Shard 0's patients copied into shard 1's manifest: p0 twice, p1 lost.
  shard(0, {ok("p0")});
  shard(1, {ok("p0")});
  CHECK_THROWS_WITH(gimm::merge_dataset(root, ""), Contains("patient 'p0' is in") &&
                                                       Contains("manifest.shard-0-of-2.json") &&
                                                       Contains("manifest.shard-1-of-2.json"));
  // p1 lost from shard 1: p2, shard 0's, stands where p1 should.
  shard(0, {ok("p0"), ok("p2")});
  shard(1, {ok("p3")});
  CHECK_THROWS_WITH(gimm::merge_dataset(root, ""),
                    Contains("'p2'") && Contains("belongs to shard 1") && Contains("missing"));
  // Ids that are no folder name, splits that are none, and records that are no records.
  shard(1, {ok("../evil")});
  CHECK_THROWS_WITH(gimm::merge_dataset(root, ""), Contains("../evil"));
  shard(1, {ok("p1", "bogus")});
  CHECK_THROWS_WITH(gimm::merge_dataset(root, ""), Contains("bogus") && Contains("split"));
  shard(1, "p1");
  CHECK_THROWS_WITH(gimm::merge_dataset(root, ""), Contains("manifest.shard-1-of-2.json") &&
                                                       Contains("'patients' must be an array"));
  shard(1, {{{"status", "ok"}}});
  CHECK_THROWS_WITH(gimm::merge_dataset(root, ""),
                    Contains("manifest.shard-1-of-2.json") && Contains("string 'id'"));
  CHECK_FALSE(fs::exists(root / "manifest.json"));  // nothing merged on failure
  shard(0, {ok("p0"), ok("p2")});
  shard(1, {ok("p1"), ok("p3", "val")});
  CHECK(gimm::merge_dataset(root, "").manifest.at("patients").size() == 4);
}

TEST_CASE("Dataset run: a finished patient made with other parameters is refused", "[dataset]") {
  const fs::path root = fresh("resume");
  const gimm::DatasetLayout layout(root);
  fs::create_directories(layout.patient_dir("p"));
  CHECK(gimm::finished_patient(layout, "p", {{"seed", 1}}).is_null());
  gimm::write_json_file(layout.done_record("p"),
                        {{"id", "p"}, {"status", "ok"}, {"run", {{"seed", 1}}}});
  gimm::write_file_atomic(layout.patient_dir("p") / "t.txt", std::string("x"));
  fs::rename(layout.patient_dir("p") / "t.txt", layout.patient_dir("p") / "a.json.tmp.h.2");
  CHECK(gimm::finished_patient(layout, "p", {{"seed", 1}}) == json{{"id", "p"}, {"status", "ok"}});
  CHECK_FALSE(fs::exists(layout.patient_dir("p") / "a.json.tmp.h.2"));  // swept
  CHECK_THROWS_WITH(gimm::finished_patient(layout, "p", {{"seed", 2}}),
                    Catch::Contains("/seed: 1 there, 2 here"));
  // A record that is not this patient's finished one would go into the manifest as it is
  // (before: an array threw nlohmann's own error, another id was taken).
  const std::string where = layout.done_record("p").string();
  for (const json& bad : {json::array({1, 2}), json{{"id", "p"}, {"status", "ok"}},
                          json{{"id", "q"}, {"status", "ok"}, {"run", {{"seed", 1}}}},
                          json{{"id", "p"}, {"status", "failed"}, {"run", {{"seed", 1}}}},
                          json{{"id", "p"}, {"run", {{"seed", 1}}}}}) {
    INFO(bad.dump());
    gimm::write_json_file(layout.done_record("p"), bad);
    CHECK_THROWS_AS(gimm::finished_patient(layout, "p", {{"seed", 1}}), gimm::FormatError);
    CHECK_THROWS_WITH(gimm::finished_patient(layout, "p", {{"seed", 1}}),
                      Catch::Contains(where) && Catch::Contains("remove the patient's folder"));
  }
}

TEST_CASE("Dataset shard: flags and job-array indices", "[dataset]") {
  CHECK(gimm::resolve_shard("1/3").index == 1);
  CHECK(gimm::resolve_shard("1/3").count == 3);
  CHECK_THROWS_WITH(gimm::resolve_shard("3/3"), Catch::Contains("out of range"));
  CHECK_THROWS_WITH(gimm::resolve_shard("x/3"), Catch::Contains("'x'"));
  CHECK_THROWS_WITH(gimm::resolve_shard("2"), Catch::Contains("I/N"));
}
