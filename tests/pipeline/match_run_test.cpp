// Matching a whole dataset (pipeline/match_run.hpp): each pair's file is what the matcher gives
// for that pair's input built here from the dataset's files, a pair's random stream does not
// depend on the other pairs, options that do not fit are refused by name, and a failed run
// leaves the output folder as it was.
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "gimm/io/files.hpp"
#include "gimm/io/png.hpp"
#include "gimm/match/baselines.hpp"
#include "gimm/match/geometric.hpp"
#include "gimm/pipeline/dataset_run.hpp"
#include "gimm/pipeline/match_run.hpp"
#include "pipeline_fixtures.hpp"

namespace fs = std::filesystem;
using namespace gimm;

namespace {

/// Two phantom patients at 96 px (one in train, one in val), formed views included, made once.
const fs::path& formed_dataset() {
  static const fs::path root = [] {
    const fs::path out = gimm_test::fresh_pipeline_dir("match_run", "dataset", false);
    DatasetOptions o;
    o.carm.rows = o.carm.cols = 96;
    o.carm.pixel_mm = 2.5;
    o.seed = 5;
    o.form_angiogram = true;
    o.split_train = o.split_val = 0.5;  // of two patients: one each
    std::vector<PatientSource> sources(2);
    for (int k = 0; k < 2; ++k) {
      sources[k].id = "phantom-000" + std::to_string(k);
      sources[k].phantom_seed = 11 + k;
    }
    DatasetRunOptions run;
    run.report = [](RunMessage, const std::string&) {};
    (void)run_dataset(sources, o, out, run);
    return out;
  }();
  return root;
}

std::vector<unsigned char> bytes(const fs::path& p) {
  return read_file_bytes(p);
}

}  // namespace

TEST_CASE("Dataset matching: each file is the matcher's answer for that pair's files",
          "[pipeline][match_run]") {
  const fs::path& ds = formed_dataset();
  const fs::path out = gimm_test::fresh_pipeline_dir("match_run", "geometric", false);
  const GeometricMatcher matcher;  // follows the dataset's masks, inside the exposed fields
  std::vector<std::pair<RunMessage, std::string>> said;
  MatchRunOptions run;
  run.report = [&](RunMessage kind, const std::string& text) { said.emplace_back(kind, text); };
  const MatchRunSummary s = match_dataset(matcher, ds, out, run);
  DatasetReader reader(ds);
  const auto ids = reader.pair_ids();
  REQUIRE(ids.size() == 54);
  CHECK(s.pairs == ids.size());
  CHECK(s.formed);  // automatic: the dataset has formed views
  REQUIRE(said.size() == ids.size() + 1);
  CHECK(said.front().second.rfind("1/54 pairs, ", 0) == 0);
  CHECK(said[ids.size() - 1].second.rfind("54/54 pairs, ", 0) == 0);
  CHECK(said.back().first == RunMessage::end);
  std::size_t total = 0;
  for (const std::string& id : ids) {
    INFO(id);
    // The input built from the dataset's files by hand: labels, masks, cameras, fields.
    const PairTruth truth = reader.pair(id);
    const std::string patient = split_pair_id(id).first;
    const Image<std::uint8_t> fa = read_png8(reader.layout().view_field(patient, truth.view_a));
    const Image<std::uint8_t> fb = read_png8(reader.layout().view_field(patient, truth.view_b));
    PairInput input;
    input.id = id;
    input.truth = &truth;
    input.mask_a = truth.mask_a.get();
    input.mask_b = truth.mask_b.get();
    input.field_a = &fa;
    input.field_b = &fb;
    input.camera_a = reader.camera(patient, truth.view_a);
    input.camera_b = reader.camera(patient, truth.view_b);
    const PairMatches expected = matcher.match(input);
    const PairMatches written = read_matches(matches_path(out, id));
    CHECK(written.points_a == expected.points_a);
    CHECK(written.points_b == expected.points_b);
    CHECK(written.confidence == expected.confidence);
    CHECK(written.F_source == "cameras");
    total += written.size();
  }
  CHECK(total == s.matches);
  CHECK(total > 0);
}

TEST_CASE("Dataset matching: a pair's random stream does not depend on the other pairs",
          "[pipeline][match_run]") {
  // Cameras moved at random and the oracle's noise: a pair matched in a run of its split gives
  // the file it gets in a run of all pairs.
  const fs::path& ds = formed_dataset();
  const GeometricMatcher geometric;
  const OracleMatcher oracle(2.0, 9);
  fs::path moved;  // the geometric matcher's run of all pairs, cameras moved
  for (const PairMatcher* m :
       {static_cast<const PairMatcher*>(&geometric), static_cast<const PairMatcher*>(&oracle)}) {
    INFO(m->name());
    MatchRunOptions all;
    all.seed = 4;
    if (m == &geometric) all.camera_error = {1.0, 2.0};
    MatchRunOptions train = all;
    train.split = "train";
    const fs::path out_all = gimm_test::fresh_pipeline_dir("match_run", m->name() + "-all", false);
    const fs::path out_train =
        gimm_test::fresh_pipeline_dir("match_run", m->name() + "-train", false);
    (void)match_dataset(*m, ds, out_all, all);
    if (m == &geometric) moved = out_all;
    const MatchRunSummary t = match_dataset(*m, ds, out_train, train);
    const auto ids = DatasetReader(ds).pair_ids("train");
    REQUIRE(t.pairs == ids.size());
    REQUIRE(ids.size() > 0);
    REQUIRE(ids.size() < 54);
    for (const std::string& id : ids)
      CHECK(bytes(matches_path(out_train, id)) == bytes(matches_path(out_all, id)));
  }
  // And the moved cameras change the answer (the error is applied).
  const fs::path exact = gimm_test::fresh_pipeline_dir("match_run", "exact", false);
  (void)match_dataset(geometric, ds, exact, {});
  const std::string id = DatasetReader(ds).pair_ids("train").front();
  CHECK(bytes(matches_path(exact, id)) != bytes(matches_path(moved, id)));
}

TEST_CASE("Dataset matching: options that do not fit are refused by name, nothing written",
          "[pipeline][match_run]") {
  const fs::path& ds = formed_dataset();
  const fs::path out = gimm_test::fresh_pipeline_dir("match_run", "refused", false);
  const GeometricMatcher masks;
  const OracleMatcher oracle(1.0, 0);
  MatchRunOptions o;
  o.use_cameras = false;
  o.camera_error.deg = 1;
  CHECK_THROWS_WITH(match_dataset(masks, ds, out, o),
                    Catch::Contains("MatchRunOptions::camera_error moves the cameras"));
  o = {};
  o.degradation.blur_px = 1;
  CHECK_THROWS_WITH(match_dataset(oracle, ds, out, o),
                    Catch::Contains("the oracle matcher does not look at them"));
  o = {};
  o.degradation.photons = 0.5;
  CHECK_THROWS_WITH(match_dataset(oracle, ds, out, o),
                    Catch::Contains("ImageDegradation::photons must be 0"));
  o = {};
  o.camera_error.deg = 50;
  CHECK_THROWS_WITH(match_dataset(masks, ds, out, o), Catch::Contains("CameraError::deg"));
  o = {};
  o.split = "tests";
  CHECK_THROWS_WITH(match_dataset(masks, ds, out, o), Catch::Contains("MatchRunOptions::split"));
  o = {};
  o.split = "test";
  CHECK_THROWS_WITH(match_dataset(oracle, ds, out, o), Catch::Contains("no pairs in"));
  CHECK_FALSE(fs::exists(out));
}

TEST_CASE("Dataset matching: a failed run leaves the output as it was", "[pipeline][match_run]") {
  // A copy of the dataset whose last pair file is corrupt: the run fails there, after every
  // other pair was matched, and the output folder keeps its earlier file and gains nothing.
  const fs::path copy = gimm_test::fresh_pipeline_dir("match_run", "corrupt", false);
  fs::copy(formed_dataset(), copy, fs::copy_options::recursive);
  DatasetReader reader(copy);
  const std::string last = reader.pair_ids().back();
  {
    std::ofstream f(reader.layout().pair_labels(last), std::ios::trunc);
    f << "{\"format\": ";
  }
  const fs::path out = gimm_test::fresh_pipeline_dir("match_run", "kept", true);
  write_file_atomic(out / "earlier.txt", "an earlier run's file");
  CHECK_THROWS(match_dataset(OracleMatcher(1.0, 0), copy, out, {}));
  std::size_t files = 0;
  for (const auto& e : fs::recursive_directory_iterator(out)) files += e.is_regular_file();
  CHECK(files == 1);
  const std::vector<unsigned char> kept = read_file_bytes(out / "earlier.txt");
  CHECK(std::string(kept.begin(), kept.end()) == "an earlier run's file");
}
