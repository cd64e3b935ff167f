// The reference-layout export on a real gimm dataset (two small phantom patients, 96 x 96
// views, shared views): file names as the reference code parses them, scene and dense-label
// JSON keys, 2D/3D labels equal to gimm's pair files, images and masks, list files per split,
// and errors that name the file and the bad value.
#include <catch2/catch.hpp>
#include <filesystem>
#include <set>
#include <sstream>

#include "gimm/pipeline/patient.hpp"
#include "gimm/pipeline/reference_export.hpp"

// Its own namespace: the tests are compiled as one file (tests/CMakeLists.txt).
namespace reference_export_test {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

const fs::path& tmp_root() {
  static const fs::path root = fs::path(GIMM_TEST_TMP) / "pipeline" / "reference_export";
  return root;
}

/// A gimm dataset of patients "7" (train) and "phantom-0012" (test), plus a failed patient,
/// with a manifest as gimm-dataset writes it (splits set here so every list is exercised).
const fs::path& gimm_dataset() {
  static const fs::path dir = [] {
    const fs::path d = tmp_root() / "gimm";
    fs::remove_all(d);
    fs::create_directories(d);
    gimm::DatasetOptions o;
    o.carm.rows = o.carm.cols = 96;
    o.carm.pixel_mm = 2.5;
    json patients = json::array();
    for (const auto& [id, seed, split] :
         {std::tuple<std::string, int, std::string>{"7", 3, "train"},
          {"phantom-0012", 5, "test"}}) {
      gimm::PatientSource src;
      src.id = id;
      src.phantom_seed = static_cast<std::uint64_t>(seed);
      src.phantom_size = gimm::PhantomSize::small;
      json record = gimm::generate_patient(src, o, d);
      record["split"] = split;
      patients.push_back(record);
    }
    patients.push_back({{"id", "9"}, {"status", "failed"}, {"error", "no label"}});
    gimm::write_json_file(d / "manifest.json", {{"format", "gimm-dataset/1"},
                                                {"parameters", o.to_json()},
                                                {"input", {{"phantom", 2}}},
                                                {"patients", patients}});
    return d;
  }();
  return dir;
}

const fs::path& exported() {
  static const fs::path out = [] {
    const fs::path o = tmp_root() / "reference";
    fs::remove_all(o);
    gimm::export_reference(gimm_dataset(), o);
    return o;
  }();
  return out;
}

std::string slurp(const fs::path& p) {
  const auto bytes = gimm::read_file_bytes(p);
  return std::string(bytes.begin(), bytes.end());
}

std::vector<std::string> split_at(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::stringstream in(s);
  std::string part;
  while (std::getline(in, part, sep)) out.push_back(part);
  return out;
}

/// What the reference evaluation derives from an image file name to find the dense-label
/// entry: drop "_A_0"/"_B_0", drop "<project1>_<project2>_<patient>_", then the first token
/// is the system and the remaining '_' are spaces in the view names.
std::string dense_key_from_file_name(const std::string& file) {
  std::string stem = fs::path(file).stem().string();
  REQUIRE(stem.size() > 4);
  stem = stem.substr(0, stem.size() - 4);
  const auto parts = split_at(stem, '_');
  REQUIRE(parts.size() >= 5);
  std::string key = parts[3] + "_" + parts[4];
  for (std::size_t k = 5; k < parts.size(); ++k) key += " " + parts[k];
  return key;
}

/// The exported pair in the dense labels for a gimm pair file.
struct GimmPair {
  json labels, cam_a, cam_b;
};

GimmPair read_gimm_pair(const fs::path& patient, const std::string& pair_file) {
  GimmPair p;
  p.labels = gimm::read_json_file(patient / "pairs" / pair_file);
  p.cam_a = gimm::read_json_file(patient / "views" /
                                 (p.labels["view_a"].get<std::string>() + ".camera.json"));
  p.cam_b = gimm::read_json_file(patient / "views" /
                                 (p.labels["view_b"].get<std::string>() + ".camera.json"));
  return p;
}

}  // namespace

TEST_CASE("Reference export: names, lists and scene files", "[pipeline][reference]") {
  const fs::path& out = exported();
  for (const char* f : {"frame_export_old.json", "train_list.txt", "val_list.txt", "test_list.txt",
                        "black_list.txt", "voxel_spacing_dict.json", "npz_scenes/split_length.txt"})
    CHECK(fs::exists(out / f));
  CHECK(slurp(out / "train_list.txt") == "angio_cip_scene_info_0007\n");
  CHECK(slurp(out / "val_list.txt").empty());
  CHECK(slurp(out / "test_list.txt") == "angio_cip_scene_info_phantom-0012\n");
  CHECK(slurp(out / "black_list.txt").empty());
  CHECK(slurp(out / "npz_scenes/split_length.txt") == "27");
  CHECK(gimm::read_json_file(out / "voxel_spacing_dict.json") ==
        json{{"0007", {1.0, 1.0, 1.0}}, {"phantom-0012", {1.0, 1.0, 1.0}}});
  // The failed patient "9" is not exported.
  CHECK_FALSE(fs::exists(out / "npz_scenes/angio_cip_scene_info_0009.json"));

  std::size_t images = 0;
  for (const auto& e : fs::directory_iterator(out / "images")) {
    ++images;
    CHECK(fs::exists(out / "masks" / e.path().filename()));
  }
  CHECK(images == 2 * 2 * 27);

  const json scene = gimm::read_json_file(out / "npz_scenes/angio_cip_scene_info_0007.json");
  for (const char* key : {"image_paths", "depth_paths", "intrinsics", "poses", "pair_infos"})
    REQUIRE(scene.contains(key));
  REQUIRE(scene.size() == 5);
  const auto& paths = scene["image_paths"];
  REQUIRE(paths.size() == 54);
  CHECK(scene["depth_paths"] == json(54, ""));
  CHECK(scene["intrinsics"] == json(54, ""));
  CHECK(scene["poses"] == json(54, ""));
  REQUIRE(scene["pair_infos"].size() == 27);
  for (std::size_t k = 0; k < 27; ++k) {
    CHECK(scene["pair_infos"][k] == json{{2 * k, 2 * k + 1}, 1.0, {0.0, 0.0, 0.0, 0.0}});
    CHECK(fs::exists(out / "images" / paths[2 * k].get<std::string>()));
  }
  // RCA pairs first, in the reference's pair order; A/B suffixes; 4-digit patient.
  CHECK(paths[0] == "Phys_DRR_0007_RCA_AP_Cranial-LAO_A_0.png");
  CHECK(paths[1] == "Phys_DRR_0007_RCA_AP_Cranial-LAO_B_0.png");
  CHECK(paths[10] == "Phys_DRR_0007_RCA_LAO_Cranial-RAO_A_0.png");
  CHECK(paths[12] == "Phys_DRR_0007_LCA_AP-AP_Cranial_A_0.png");
  CHECK(paths[53] == "Phys_DRR_0007_LCA_RAO_Cranial-RAO_Caudal_B_0.png");

  // Every image name leads the reference's parser to an entry of the dense labels.
  const json dense = gimm::read_json_file(out / "dense_labels/angio_cip_dense_labels_0007.json");
  CHECK(dense["sample_id"] == "7");
  REQUIRE(dense["pairs"].size() == 27);
  for (const auto& p : paths) CHECK(dense["pairs"].contains(dense_key_from_file_name(p)));
  CHECK(dense["pairs"].contains("LCA_LAO Caudal-RAO Caudal"));
}

TEST_CASE("Reference export: dense and sparse labels equal gimm's", "[pipeline][reference]") {
  const fs::path& out = exported();
  const fs::path patient = gimm_dataset() / "patients" / "7";
  const json dense = gimm::read_json_file(out / "dense_labels/angio_cip_dense_labels_0007.json");
  const json frames = gimm::read_json_file(out / "frame_export_old.json");
  REQUIRE(frames.is_array());
  CHECK(frames.size() == 2 * 2 * 27);
  std::map<std::string, json> frame_of;  // "<patient>/<video_name>" -> entry
  for (const auto& f : frames) {
    for (const char* key : {"project", "patient", "video_name", "study", "label"})
      REQUIRE(f.contains(key));
    CHECK(f["project"] == "Phys_DRR");
    CHECK(f["study"] == "study_001");
    frame_of[f["patient"].get<std::string>() + "/" + f["video_name"].get<std::string>()] = f;
  }

  std::size_t checked = 0;
  for (const auto& e : fs::directory_iterator(patient / "pairs")) {
    const GimmPair g = read_gimm_pair(patient, e.path().filename().string());
    const std::string sys = g.cam_a["system"];
    const std::string va = g.cam_a["view_name"], vb = g.cam_b["view_name"];
    const std::string key = sys + "_" + va + "-" + vb;
    INFO(key);
    REQUIRE(dense["pairs"].contains(key));
    const json& d = dense["pairs"][key];
    for (const char* k : {"primary_A", "secondary_A", "primary_B", "secondary_B",
                          "vessel_points_3d", "vessel_points_A", "vessel_points_B", "centerline_3d",
                          "centerline_A", "centerline_B", "K1", "K2"})
      REQUIRE(d.contains(k));
    CHECK(d["primary_A"] == g.cam_a["primary_deg"]);
    CHECK(d["secondary_A"] == g.cam_a["secondary_deg"]);
    CHECK(d["primary_B"] == g.cam_b["primary_deg"]);
    CHECK(d["secondary_B"] == g.cam_b["secondary_deg"]);
    CHECK(d["K1"] == g.cam_a["K"]);
    CHECK(d["K2"] == g.cam_b["K"]);
    CHECK(d["gimm"]["F"] == g.labels["F"]);
    CHECK(d["gimm"]["P1"] == g.cam_a["P"]);

    const json& rows = g.labels["dense"];
    REQUIRE(d["centerline_A"].size() == rows.size());
    REQUIRE(d["centerline_3d"].size() == rows.size());
    REQUIRE(rows.size() > 0);
    for (std::size_t r = 0; r < rows.size(); ++r) {
      CHECK(d["centerline_A"][r] == json{rows[r][0], rows[r][1]});
      CHECK(d["centerline_B"][r] == json{rows[r][2], rows[r][3]});
      CHECK(d["centerline_3d"][r] == json{rows[r][4], rows[r][5], rows[r][6]});
    }
    CHECK(d["vessel_points_A"] == d["centerline_A"]);
    CHECK(d["vessel_points_B"] == d["centerline_B"]);
    CHECK(d["vessel_points_3d"] == d["centerline_3d"]);

    // Sparse: one entry per image, categories <SYS>_00.., the same index in both views.
    const std::string pair = sys + "_" + gimm::reference_format::underscored(va) + "-" +
                             gimm::reference_format::underscored(vb);
    const json& sparse = g.labels["sparse"];
    REQUIRE(sparse.size() == 20);
    for (const char side : {'A', 'B'}) {
      const std::string video = pair + "_" + side;
      REQUIRE(frame_of.count("0007/" + video));
      const json& data = frame_of["0007/" + video]["label"]["cip"]["multi_branch"]["data"];
      REQUIRE(data.size() == 1);
      REQUIRE(data[0]["pts"].size() == sparse.size());
      REQUIRE(data[0]["categories"].size() == sparse.size());
      CHECK(data[0]["categories"][0] == sys + "_00");
      CHECK(data[0]["categories"][19] == sys + "_19");
      const int off = side == 'A' ? 0 : 2;
      for (std::size_t k = 0; k < sparse.size(); ++k) {
        const json& row = rows[sparse[k].get<std::size_t>()];
        CHECK(data[0]["pts"][k] == json{row[off], row[off + 1]});
      }
    }

    // Images: 8-bit RGB, the detector size, min-max of gimm's 16-bit view; masks 0/255.
    const fs::path img = out / "images" / ("Phys_DRR_0007_" + pair + "_A_0.png");
    const auto bytes = gimm::read_file_bytes(img);
    REQUIRE(bytes.size() > 26);
    CHECK(bytes[24] == 8);  // IHDR bit depth
    CHECK(bytes[25] == 2);  // IHDR colour type: RGB
    const auto mine = gimm::read_png8(img);
    const auto src =
        gimm::read_png16(patient / "views" / (g.labels["view_a"].get<std::string>() + ".png"));
    REQUIRE(mine.rows() == 96);
    REQUIRE(mine.cols() == 96);
    const auto [lo, hi] = std::minmax_element(src.storage().begin(), src.storage().end());
    REQUIRE(*hi > *lo);
    for (std::size_t p = 0; p < src.size(); ++p)
      REQUIRE(mine.data()[p] == (src.data()[p] - *lo) * 255u / (*hi - *lo));
    const auto mask = gimm::read_png8(out / "masks" / img.filename());
    const auto gimm_mask =
        gimm::read_png8(patient / "views" / (g.labels["view_a"].get<std::string>() + ".mask.png"));
    CHECK(mask.storage() == gimm_mask.storage());
    ++checked;
  }
  CHECK(checked == 27);
}

TEST_CASE("Reference export: errors name the file and the bad value", "[pipeline][reference]") {
  const fs::path bad = tmp_root() / "bad";
  fs::remove_all(bad);
  fs::create_directories(bad);
  auto fails_with = [&](const std::string& a, const std::string& b) {
    try {
      gimm::export_reference(bad, tmp_root() / "bad_out");
      FAIL("export_reference did not throw");
    } catch (const gimm::Error& e) {
      const std::string what = e.what();
      INFO(what);
      CHECK(what.find(a) != std::string::npos);
      CHECK(what.find(b) != std::string::npos);
    }
  };
  fails_with((bad / "manifest.json").string(), "does not exist");

  gimm::write_json_file(bad / "manifest.json",
                        {{"format", "other/2"}, {"patients", json::array()}});
  fails_with((bad / "manifest.json").string(), "other/2");

  gimm::write_json_file(bad / "manifest.json",
                        {{"format", "gimm-dataset/1"},
                         {"patients", {{{"id", "a_b"}, {"split", "train"}, {"status", "ok"}}}}});
  fails_with((bad / "manifest.json").string(), "'a_b'");

  gimm::write_json_file(bad / "manifest.json",
                        {{"format", "gimm-dataset/1"},
                         {"patients", {{{"id", "1"}, {"split", "dev"}, {"status", "ok"}}}}});
  fails_with((bad / "manifest.json").string(), "'dev'");

  // A pair file whose sparse index points past the dense rows.
  const fs::path src = gimm_dataset() / "patients" / "7";
  const fs::path dst = bad / "patients" / "7";
  fs::create_directories(dst);
  fs::copy(src / "views", dst / "views", fs::copy_options::recursive);
  fs::create_directories(dst / "pairs");
  json pair = gimm::read_json_file(src / "pairs" / "RCA_00-01.json");
  pair["sparse"][3] = 100000;
  gimm::write_json_file(dst / "pairs" / "RCA_00-01.json", pair);
  gimm::write_json_file(bad / "manifest.json",
                        {{"format", "gimm-dataset/1"},
                         {"patients", {{{"id", "7"}, {"split", "train"}, {"status", "ok"}}}}});
  fails_with((dst / "pairs" / "RCA_00-01.json").string(), "100000");

  // A view image whose size disagrees with its camera.
  pair["sparse"][3] = 0;
  gimm::write_json_file(dst / "pairs" / "RCA_00-01.json", pair);
  gimm::write_png(dst / "views" / "RCA_00.png", gimm::Image<std::uint16_t>(5, 7, 1));
  fails_with((dst / "views" / "RCA_00.png").string(), "5 x 7");
}

TEST_CASE("Reference export: ids are checked before anything is written", "[pipeline][reference]") {
  namespace rf = gimm::reference_format;
  CHECK_NOTHROW(rf::check_patient_ids({"7", "12", "phantom-0001"}, "--export reference"));
  CHECK_THROWS_WITH(rf::check_patient_ids({"7", "a_b"}, "--export reference"),
                    Catch::Contains("--export reference: patient id 'a_b'") &&
                        Catch::Contains("splits names at '_'"));
  CHECK_THROWS_WITH(rf::check_patient_ids({"7", "0007"}, "--export reference"),
                    Catch::Contains("'7' and '0007' both export as '0007'"));

  // A good patient listed before a bad one: nothing of the good one is written either.
  const fs::path dataset = tmp_root() / "bad_id";
  fs::remove_all(dataset);
  fs::create_directories(dataset / "patients");
  fs::copy(gimm_dataset() / "patients" / "7", dataset / "patients" / "7",
           fs::copy_options::recursive);
  gimm::write_json_file(dataset / "manifest.json",
                        {{"format", "gimm-dataset/1"},
                         {"patients",
                          {{{"id", "7"}, {"split", "train"}, {"status", "ok"}},
                           {{"id", "x_1"}, {"split", "test"}, {"status", "ok"}}}}});
  const fs::path out = tmp_root() / "bad_id_out";
  fs::remove_all(out);
  CHECK_THROWS_WITH(
      gimm::export_reference(dataset, out),
      Catch::Contains("patient id 'x_1'") && Catch::Contains((dataset / "manifest.json").string()));
  CHECK(!fs::exists(out / "images"));

  // A dataset made from a view list (gimm-dataset --views) is refused by the library too, before
  // anything is written, naming the manifest.
  gimm::write_json_file(dataset / "manifest.json",
                        {{"format", "gimm-dataset/1"},
                         {"parameters", {{"view_mode", "listed"}}},
                         {"patients", {{{"id", "7"}, {"split", "train"}, {"status", "ok"}}}}});
  CHECK_THROWS_WITH(gimm::export_reference(dataset, out),
                    Catch::Contains("made from a view list") &&
                        Catch::Contains((dataset / "manifest.json").string()));
  CHECK(!fs::exists(out));
}

}  // namespace reference_export_test
