// One patient through generate_patient from NIfTI files: what the split leaves out is recorded
// (and warned about past the threshold), a single-tree label fails naming the flag or, with
// allow_single_system, makes the present system only; timings go to the caller, never to
// done.json.
#include <algorithm>
#include <catch2/catch.hpp>
#include <filesystem>
#include <set>

#include "gimm/io/nifti.hpp"
#include "gimm/pipeline/dataset_run.hpp"
#include "gimm/pipeline/patient.hpp"
#include "pipeline_fixtures.hpp"

namespace fs = std::filesystem;
using namespace gimm;
using nlohmann::json;

namespace {
const fs::path& tmp_root() {
  static const fs::path root = fs::path(GIMM_TEST_TMP) / "pipeline" / "patient";
  return root;
}

DatasetOptions small_views() {
  DatasetOptions o;
  o.carm.rows = o.carm.cols = 96;
  o.carm.pixel_mm = 2.5;
  return o;
}

const Phantom& phantom() {
  static const Phantom p = [] {
    PhantomOptions po;
    po.seed = 3;
    return make_phantom(po);
  }();
  return p;
}

/// Patient `id` in its own input folder: the phantom's CT with `label`.
PatientSource write_patient(const std::string& id, const Volume<std::uint8_t>& label) {
  const fs::path in = tmp_root() / ("in-" + id);
  fs::remove_all(in);
  fs::create_directories(in);
  PatientSource src;
  src.id = id;
  src.image = in / (id + ".img.nii.gz");
  src.label = in / (id + ".label.nii.gz");
  write_nifti(src.image, phantom().hu);
  write_nifti(src.label, label);
  return src;
}

fs::path fresh_out(const std::string& name) {
  return gimm_test::fresh_pipeline_dir("patient", name, false);
}

std::set<std::string> file_prefixes(const fs::path& dir) {
  std::set<std::string> out;
  for (const auto& e : fs::directory_iterator(dir))
    out.insert(e.path().filename().string().substr(0, 3));
  return out;
}
}  // namespace

TEST_CASE("Patient: voxels the split drops are recorded and warned about", "[pipeline][patient]") {
  Volume<std::uint8_t> label = phantom().label;
  const std::int64_t vessel = std::count(label.storage().begin(), label.storage().end(), 1);
  // A third tree, away from the two: a 6^3 block in a corner of the grid.
  for (int k = 1; k < 7; ++k)
    for (int j = 1; j < 7; ++j)
      for (int i = 1; i < 7; ++i) {
        REQUIRE(label(i, j, k) == 0);
        label(i, j, k) = 1;
      }
  const PatientSource src = write_patient("11", label);
  DatasetOptions o = small_views();
  const fs::path out = fresh_out("dropped");
  const json record = generate_patient(src, o, out);
  const json& l = record.at("label");
  CHECK(l.at("voxels") == vessel + 216);
  CHECK(l.at("components") == 3);
  CHECK(l.at("dropped_components") == 1);
  CHECK(l.at("dropped_voxels") == 216);
  CHECK(l.at("dropped_fraction").get<double>() == Approx(216.0 / (vessel + 216)));
  CHECK(record["systems"]["LCA"]["voxels"].get<std::int64_t>() +
            record["systems"]["RCA"]["voxels"].get<std::int64_t>() ==
        vessel);
  // done.json holds the same record (and what it depends on).
  json stored = read_json_file(out / "patients" / "11" / "done.json");
  stored.erase("run");
  CHECK(stored == record);

  REQUIRE(216.0 / (vessel + 216) > 0.05);
  const std::string warning = dropped_voxels_warning(record, o);
  INFO(warning);
  CHECK(warning.find("patient 11") != std::string::npos);
  CHECK(warning.find("216 of " + std::to_string(vessel + 216)) != std::string::npos);
  CHECK(warning.find("threshold 5%") != std::string::npos);
  o.warn_dropped_fraction = 0.5;
  CHECK(dropped_voxels_warning(record, o).empty());
}

TEST_CASE("Patient: a single-tree label fails naming the option, or makes that system only",
          "[pipeline][patient]") {
  const CoronarySplit split = split_coronary_systems(phantom().label);
  const PatientSource src = write_patient("12", split.lca);
  DatasetOptions o = small_views();
  CHECK_THROWS_WITH(
      generate_patient(src, o, fresh_out("single_refused")),
      Catch::Contains("patient 12 label") && Catch::Contains("SplitOptions::allow_single"));

  o.allow_single_system = true;
  const fs::path out = fresh_out("single");
  const json record = generate_patient(src, o, out);
  CHECK(record["status"] == "ok");
  const json& lca = record["systems"]["LCA"];
  const json& rca = record["systems"]["RCA"];
  CHECK(lca["present"] == true);
  CHECK(lca["voxels"] == split.lca_voxels);
  CHECK(lca["views"] == 7);
  CHECK(lca["pairs"] == 21);
  CHECK(lca["dense_labels"].get<int>() > 0);
  CHECK(rca == json{{"present", false},
                    {"voxels", 0},
                    {"views", 0},
                    {"pairs", 0},
                    {"centerline_mm", 0.0},
                    {"dense_labels", 0}});
  CHECK(record["label"]["components"] == 1);
  CHECK(record["label"]["dropped_voxels"] == 0);
  const fs::path pdir = out / "patients" / "12";
  CHECK(file_prefixes(pdir / "views") == std::set<std::string>{"LCA"});
  CHECK(file_prefixes(pdir / "pairs") == std::set<std::string>{"LCA"});
  std::size_t views = 0;
  for (const auto& e : fs::directory_iterator(pdir / "views"))
    views += e.path().filename().string().find(".camera.json") != std::string::npos;
  CHECK(views == 7);
  const json centerlines = read_json_file(pdir / "centerlines.json");
  for (const auto& b : centerlines["branches"]) CHECK(b["system"] == "LCA");
  CHECK(read_json_file(pdir / "done.json")["run"]["parameters"]["allow_single_system"] == true);
}

TEST_CASE("Patient: stage timings go to the caller, never into the dataset",
          "[pipeline][patient]") {
  PatientSource src;
  src.id = "p";
  src.phantom_seed = 5;
  const fs::path out = fresh_out("timings");
  PatientTimings t;
  const json record = generate_patient(src, small_views(), out, &t);
  CHECK(t.total > 0);
  CHECK(t.read > 0);
  CHECK(t.views > 0);
  CHECK(t.view_count == 11);
  CHECK(t.total >= t.read + t.split + t.centerlines + t.attenuation + t.views);
  // No file of the patient holds seconds: the dataset is byte-reproducible.
  for (const auto& entry : fs::recursive_directory_iterator(out / "patients" / "p"))
    if (entry.path().extension() == ".json")
      CHECK(read_json_file(entry.path()).dump().find("seconds") == std::string::npos);
  CHECK_FALSE(fs::exists(out / "patients" / "p" / "timings.json"));
  const json file = t.to_json();
  CHECK(file["views"] == 11);
  for (const char* stage :
       {"total", "read", "split", "centerlines", "attenuation", "mesh", "views", "pairs", "writes"})
    CHECK(file["seconds"].contains(stage));
  const std::string done = read_json_file(out / "patients" / "p" / "done.json").dump();
  CHECK(done.find("seconds") == std::string::npos);
  CHECK(record.dump().find("seconds") == std::string::npos);
  const std::string line = t.summary();
  for (const char* stage : {"read ", "split ", "centerlines ", "attenuation ", "mesh ", "views ",
                            "pairs ", "writes ", "s per view"})
    CHECK(line.find(stage) != std::string::npos);
}

TEST_CASE("Dataset run: messages go to the caller's reporter, in the library's words",
          "[pipeline][patient]") {
  // Two patients: one made, one whose label splits into one tree only (it fails). Every message
  // reaches the reporter, none names a program or a flag, and the run ends once.
  const CoronarySplit split = split_coronary_systems(phantom().label);
  std::vector<PatientSource> sources = {write_patient("21", phantom().label),
                                        write_patient("22", split.lca)};
  std::vector<std::pair<RunMessage, std::string>> said;
  DatasetRunOptions run;
  run.report = [&](RunMessage kind, const std::string& text) { said.emplace_back(kind, text); };
  const DatasetRunSummary s = run_dataset(sources, small_views(), fresh_out("reporter"), run);
  CHECK(s.failed == 1);
  const auto count = [&](RunMessage kind, const std::string& part) {
    return std::count_if(said.begin(), said.end(), [&](const auto& m) {
      return m.first == kind && m.second.find(part) != std::string::npos;
    });
  };
  CHECK(count(RunMessage::info, "patient 21: ") == 1);
  CHECK(count(RunMessage::error, "patient 22 failed: ") == 1);
  CHECK(count(RunMessage::error, "SplitOptions::allow_single") == 1);
  CHECK(count(RunMessage::progress, "2/2 patients (0 resumed, 1 failed)") == 1);
  REQUIRE(!said.empty());
  CHECK(said.back().first == RunMessage::end);
  for (const auto& [kind, text] : said) {
    INFO(text);
    CHECK(text.find("gimm-") == std::string::npos);
    CHECK(text.find("--") == std::string::npos);
  }
  // quiet: the failure still, no per-patient lines and no progress.
  said.clear();
  run.quiet = true;
  (void)run_dataset(sources, small_views(), fresh_out("reporter_quiet"), run);
  CHECK(count(RunMessage::info, "patient 21: ") == 0);
  CHECK(count(RunMessage::progress, "") == 0);
  CHECK(count(RunMessage::error, "patient 22 failed: ") == 1);
}
