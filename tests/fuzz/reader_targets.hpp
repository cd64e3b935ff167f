#pragma once
// Every reader of gimm that takes a file, as a fuzz target: a name, the file suffix the reader
// picks its format by, the read, and a seed (a small valid file, written by gimm's own writers
// or taken from the committed fixtures). Shared by the mutation harness (readers_fuzz.cpp, run
// by ctest) and the coverage-guided libFuzzer targets (reader_libfuzzer.cpp, tests/fuzz/run.sh).
//
// A reader may refuse a file with gimm::Error (or a subclass); anything else escaping is a
// defect, as is a crash or undefined behaviour (the targets are built with ASan + UBSan).
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/dataset/centerlines_json.hpp"
#include "gimm/dataset/reader.hpp"
#include "gimm/dataset/run.hpp"
#include "gimm/geometry/carm.hpp"
#include "gimm/io/camera_json.hpp"
#include "gimm/io/files.hpp"
#include "gimm/io/nifti.hpp"
#include "gimm/io/npy.hpp"
#include "gimm/io/png.hpp"
#include "gimm/io/volume_file.hpp"
#include "gimm/labels/view_list.hpp"
#include "gimm/match/matches.hpp"
#include "gimm/match/tree_file.hpp"
#include "gimm/metrics/report.hpp"
#include "gimm/metrics/summary.hpp"
#include "gimm/metrics/user_truth.hpp"
#include "gimm/nn/matcher_file.hpp"
#include "gimm/nn/safetensors.hpp"
#ifdef GIMM_FUZZ_DICOM
#include "gimm/io/dicom.hpp"
#endif

namespace gimm_fuzz {

namespace fs = std::filesystem;

struct ReaderTarget {
  std::string name;
  std::string suffix;                               ///< readers that pick the format by name
  std::function<void(const fs::path&)> read;        ///< throws gimm::Error on a bad file
  std::function<void(const fs::path&)> write_seed;  ///< a small valid file at the path
};

inline void copy_fixture(const fs::path& fixture, const fs::path& to) {
  const std::vector<unsigned char> b = gimm::read_file_bytes(fixture);
  gimm::write_file_atomic(to, b.data(), b.size());
}

inline void write_text(const fs::path& to, const std::string& text) {
  gimm::write_file_atomic(to, text.data(), text.size());
}

inline gimm::Volume<float> seed_volume() {
  gimm::VolumeGeometry g;
  g.dims = {5, 4, 3};
  g.spacing = {0.7, 0.8, 1.5};
  gimm::Volume<float> vol(g, 0.0f);
  for (std::size_t i = 0; i < vol.size(); ++i) vol.data()[i] = float(i) - 20.0f;
  return vol;
}

/// A valid pair file of a gimm dataset (what DatasetReader::pair reads): two dense labels.
inline std::string seed_pair_json() {
  return R"({"view_a": "LCA_00", "view_b": "LCA_01", "view_class_a": 5, "view_class_b": 9,
"F": [[0, 0, 0], [0, 0, -1], [0, 1, 0]], "F_convention": "x_b^T F x_a = 0, pixels",
"dense_fields": ["u_a", "v_a", "u_b", "v_b", "x_mm", "y_mm", "z_mm", "radius_mm", "branch", "depth_a"],
"dense": [[10.5, 20.25, 30, 20.25, 1, 2, 3, 1.5, 0, 700], [11, 21, 31, 21, 1.5, 2.5, 3.5, 1.4, 0, 701]],
"sparse": [0]})";
}

/// The "run" of a resumed patient's record (what its files depend on), as the seed writes it.
inline nlohmann::json seed_run_record() {
  return {{"parameters", {{"seed", 1}, {"view_mode", "shared"}}},
          {"input", {{"phantom_seed", 7}}},
          {"split", "train"}};
}

/// Where a harness writes a target's input before reading it: <scratch>/fuzz_readers/<name><suffix>
/// (the matches reader checks the file's place against the pair id inside).
inline fs::path input_path(const fs::path& scratch, const ReaderTarget& t) {
  return scratch / "fuzz_readers" / (t.name + t.suffix);
}

/// {fixtures}: the committed test data (tests/data).
inline std::vector<ReaderTarget> reader_targets(const fs::path& fixtures) {
  std::vector<ReaderTarget> t;
  const auto read_nifti = [](const fs::path& p) { (void)gimm::read_nifti<float>(p); };
  const auto write_nifti = [](const fs::path& p) { gimm::write_nifti(p, seed_volume()); };
  t.push_back({"nifti", ".nii", read_nifti, write_nifti});
  t.push_back({"nifti_gz", ".nii.gz", read_nifti, write_nifti});
  // The in-memory path (.nii.gz inflated, or bytes a caller already holds).
  t.push_back({"nifti_memory", ".nii",
               [](const fs::path& p) {
                 (void)gimm::nifti_from_bytes<float>(gimm::read_file_bytes(p), p.string());
               },
               write_nifti});
  const auto read_volume = [](const fs::path& p) { (void)gimm::read_volume<float>(p); };
  const fs::path volumes = fixtures / "volumes";
  t.push_back({"nrrd", ".nrrd", read_volume,
               [=](const fs::path& p) { copy_fixture(volumes / "ct.nrrd", p); }});
  t.push_back({"metaimage", ".mha", read_volume,
               [=](const fs::path& p) { copy_fixture(volumes / "ct.mha", p); }});
  // Detached headers: the fuzzed header names its data file (beside it, copied there).
  const auto detached = [=](const char* raw) {
    return [=](const fs::path& p) {
      if (!fs::exists(p.parent_path() / raw)) copy_fixture(volumes / raw, p.parent_path() / raw);
      (void)gimm::read_volume<float>(p);
    };
  };
  t.push_back({"nhdr", ".nhdr", detached("ct_nhdr.raw"),
               [=](const fs::path& p) { copy_fixture(volumes / "ct_nhdr.nhdr", p); }});
  t.push_back({"mhd", ".mhd", detached("ct_mhd.raw"),
               [=](const fs::path& p) { copy_fixture(volumes / "ct_mhd.mhd", p); }});
  const auto read_png = [](const fs::path& p) { (void)gimm::read_png_unit(p); };
  t.push_back({"png8", ".png", read_png, [](const fs::path& p) {
                 gimm::Image<std::uint8_t> im(9, 7);
                 for (std::size_t i = 0; i < im.size(); ++i) im.data()[i] = std::uint8_t(i * 7);
                 gimm::write_png(p, im);
               }});
  t.push_back({"png16", ".png", read_png, [](const fs::path& p) {
                 gimm::Image<std::uint16_t> im(6, 5);
                 for (std::size_t i = 0; i < im.size(); ++i) im.data()[i] = std::uint16_t(i * 2000);
                 gimm::write_png(p, im);
               }});
  t.push_back({"npy", ".npy", [](const fs::path& p) { (void)gimm::read_npy_image<float>(p); },
               [](const fs::path& p) { gimm::write_npy(p, gimm::Image<float>(4, 6, 0.5f)); }});
  const fs::path nn = fixtures / "nn";
  t.push_back({"safetensors", ".safetensors",
               [](const fs::path& p) { (void)gimm::nn::SafetensorsFile::load(p.string()); },
               [=](const fs::path& p) { copy_fixture(nn / "parity_expected.safetensors", p); }});
  t.push_back({"matcher", ".safetensors",
               [](const fs::path& p) { (void)gimm::nn::load_matcher(p.string()); },
               [=](const fs::path& p) { copy_fixture(nn / "parity_weights.safetensors", p); }});
  t.push_back(
      {"camera", ".json",
       [](const fs::path& p) { (void)gimm::camera_from_json(gimm::read_json_file(p), p.string()); },
       [](const fs::path& p) {
         gimm::CArm arm;
         arm.rows = arm.cols = 64;
         gimm::write_json_file(p, gimm::to_json(arm.camera()));
       }});
  t.push_back({"matches", ".json", [](const fs::path& p) { (void)gimm::read_matches(p); },
               [](const fs::path& p) {
                 gimm::PairMatches m;
                 // The pair id names the place it is read from (input_path): <folder>/<stem>.
                 m.pair = p.parent_path().filename().string() + "/" + p.stem().string();
                 m.add({1, 2}, {3, 4}, 0.5);
                 m.add({5, 6}, {7, 8}, 0.25);
                 gimm::write_matches(p, m);
               }});
  t.push_back({"centerlines", ".json", [](const fs::path& p) { (void)gimm::read_centerlines(p); },
               [](const fs::path& p) {
                 gimm::CenterlineTree tree;
                 gimm::CenterlineBranch b;
                 b.name = "LAD";
                 b.points = {{0, 0, 0}, {1, 2, 3}, {2, 4, 5}};
                 b.radii = {1.5, 1.4, 1.2};
                 tree.branches.push_back(b);
                 gimm::write_json_file(p, gimm::to_json(tree));
               }});
  // A view list (gimm-dataset --views).
  t.push_back({"view_list", ".json", [](const fs::path& p) { (void)gimm::read_view_list(p); },
               [](const fs::path& p) {
                 write_text(p, R"({"format": "gimm-views/1", "note": "seed", "pairs": [)"
                               R"({"system": "LCA", "a": {"primary": 30, "secondary": 0},)"
                               R"( "b": {"primary": 35, "secondary": 0}},)"
                               R"({"system": "RCA", "a": {"primary": 45, "secondary": 0},)"
                               R"( "b": {"primary": -30, "secondary": 5}}]})");
               }});
  // Dataset JSON: a pair file (labels, F, classes) and a manifest (format, patients).
  t.push_back({"pair", ".json",
               [](const fs::path& p) {
                 (void)gimm::pair_truth_from_json(gimm::read_json_file(p), "fuzz/pair", p.string());
               },
               [](const fs::path& p) { write_text(p, seed_pair_json()); }});
  t.push_back({"manifest", ".json",
               [](const fs::path& p) {
                 // The reader wants <root>/manifest.json beside <root>/patients/.
                 const fs::path root = p.parent_path() / (p.stem().string() + "_dataset");
                 fs::create_directories(root / "patients" / "p0");  // the seed's ok patient
                 // Not fs::copy_file: its sendfile is not retried on EINTR, and libFuzzer's timer
                 // signal interrupted it (a harness failure after 637,136 inputs).
                 const std::vector<unsigned char> bytes = gimm::read_file_bytes(p);
                 write_text(root / "manifest.json", std::string(bytes.begin(), bytes.end()));
                 const gimm::DatasetReader reader(root);
                 (void)reader.patients();
               },
               [](const fs::path& p) {
                 write_text(p, std::string(R"({"format": ")") + gimm::kDatasetFormat +
                                   R"(", "patients": [{"id": "p0", "status": "ok"},
{"id": "p1", "status": "failed"}]})");
               }});
  // A user's sparse truth (gimm-eval --truth), a triangulated tree (gimm-eval --tree), an
  // earlier run's summary (gimm-eval --compare).
  t.push_back({"truth", ".json", [](const fs::path& p) { (void)gimm::read_user_truth(p, 3.0); },
               [](const fs::path& p) {
                 write_text(p, R"({"format": "gimm-truth/1", "pair": "p/LCA_00-01",
"points_a": [[10, 12.5], [40, 20]], "points_b": [[11, 30], [52, 25]],
"world_mm": [[1, 2, 3], [4, 5, 6]], "F": [[0, 0, 0], [0, 0, -1], [0, 1, 0]]})");
               }});
  t.push_back({"tree", ".json", [](const fs::path& p) { (void)gimm::read_tree_file(p); },
               [](const fs::path& p) {
                 gimm::TreeFile tree;
                 for (int k = 0; k < 3; ++k) {
                   gimm::TreePoint pt;
                   pt.a = {10.0 + k, 20};
                   pt.b = {30.0 + k, 21};
                   pt.world = {1, 2, 3.0 + k};
                   pt.confidence = 0.5;
                   if (k == 0) pt.reprojection_px = Eigen::Vector2d(0.5, 0.25);
                   if (k == 1) pt.branch = 2;
                   if (k == 2) pt.consistent = true;
                   tree.points.push_back(pt);
                 }
                 tree.dropped_degenerate = 1;
                 tree.dropped_reprojection = 0;
                 gimm::write_tree_file(p, tree);
               }});
  t.push_back({"eval_summary", ".json", [](const fs::path& p) { (void)gimm::read_eval_summary(p); },
               [](const fs::path& p) {
                 gimm::Summary s;
                 s.pairs = 3;
                 s.matches = 20;
                 s.prec[0] = 0.5;
                 s.prec[1] = 0.75;
                 s.mean_px = 2.5;
                 gimm::write_json_file(p, {{"format", gimm::kEvalFormat},
                                           {"method", "seed"},
                                           {"top_k", 20},
                                           {"pooled", gimm::to_json(s)}});
               }});
  // A finished patient's record, as a resumed run reads it (done.json).
  t.push_back({"done_record", ".json",
               [](const fs::path& p) {
                 const fs::path root = p.parent_path() / (p.stem().string() + "_dataset");
                 const gimm::DatasetLayout layout(root);
                 fs::create_directories(layout.patient_dir("p0"));
                 const std::vector<unsigned char> bytes = gimm::read_file_bytes(p);
                 write_text(layout.done_record("p0"), std::string(bytes.begin(), bytes.end()));
                 (void)gimm::finished_patient(layout, "p0", seed_run_record());
               },
               [](const fs::path& p) {
                 nlohmann::json record = {{"id", "p0"}, {"split", "train"}, {"status", "ok"}};
                 record["run"] = seed_run_record();
                 gimm::write_json_file(p, record);
               }});
#ifdef GIMM_FUZZ_DICOM
  t.push_back({"dicom", ".dcm", [](const fs::path& p) { (void)gimm::read_xa_dicom(p.string()); },
               [](const fs::path& p) {
                 gimm::CArm arm;
                 arm.rows = 6;
                 arm.cols = 8;
                 arm.primary_deg = -30;
                 arm.secondary_deg = 20;
                 gimm::Image<float> im(arm.rows, arm.cols);
                 for (std::size_t i = 0; i < im.size(); ++i) im.data()[i] = float(i) / 48.0f;
                 gimm::write_xa_dicom(p.string(), im, arm, true);
               }});
#endif
  return t;
}

}  // namespace gimm_fuzz
