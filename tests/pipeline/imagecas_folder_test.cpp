// The ImageCAS input folder: patients found in sub-folders (as ImageCAS ships them), in every
// volume format gimm reads, labels beside their images; duplicate ids and empty folders refused
// with messages naming the files, the folder and the patterns.
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <set>

#include "gimm/pipeline/patient.hpp"

namespace fs = std::filesystem;
using namespace gimm;

namespace {
fs::path fresh(const std::string& name) {
  const fs::path d = fs::path(GIMM_TEST_TMP) / "pipeline" / "imagecas_folder" / name;
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}
/// An empty file: the scan looks at names only.
void touch(const fs::path& p) {
  fs::create_directories(p.parent_path());
  std::ofstream(p) << "";
}
}  // namespace

TEST_CASE("ImageCAS ids: <id>.img<ext> for every extension gimm reads", "[pipeline][input]") {
  for (const auto& ext : volume_extensions()) {
    INFO(ext);
    CHECK(imagecas_image_id("a/1.img" + ext) == "1");
    CHECK(imagecas_image_id("a/case.7.img" + ext) == "case.7");
    CHECK(imagecas_image_id("a/1.label" + ext).empty());
    CHECK(imagecas_image_id("a/.img" + ext).empty());
    CHECK(imagecas_image_id("a/1" + ext).empty());
  }
  CHECK(imagecas_image_id("a/1.img.txt").empty());
}

TEST_CASE("ImageCAS folder: sub-folders searched, every volume format, labels beside",
          "[pipeline][input]") {
  const fs::path root = fresh("nested");
  // ImageCAS's own layout, plus one patient per extension gimm reads (new formats included).
  touch(root / "1-200" / "1.img.nii.gz");
  touch(root / "1-200" / "1.label.nii.gz");
  touch(root / "201-400" / "201.img.nii.gz");
  touch(root / "201-400" / "201.label.nii.gz");
  touch(root / "201-400" / "deeper" / "305.img.nii.gz");  // no label: kept, fails later
  std::set<std::string> want = {"1", "201", "305"};
  for (std::size_t k = 0; k < volume_extensions().size(); ++k) {
    const std::string id = "fmt" + std::to_string(k), ext = volume_extensions()[k];
    touch(root / ("f" + std::to_string(k)) / (id + ".img" + ext));
    touch(root / ("f" + std::to_string(k)) / (id + ".label" + ext));
    want.insert(id);
  }
  touch(root / "notes.txt");
  touch(root / "1-200" / "._2.img.nii.gz");       // macOS metadata beside a copied file
  touch(root / ".trash" / "3.img.nii.gz");        // hidden folder
  fs::create_directories(root / "4.img.nii.gz");  // a folder, not a volume file

  const auto found = scan_imagecas_folder(root);
  std::set<std::string> ids;
  for (const auto& p : found) {
    ids.insert(p.id);
    INFO(p.image.string());
    CHECK(p.label.parent_path() == p.image.parent_path());
    CHECK(p.label.filename().string() == p.id + ".label" + volume_extension(p.image));
  }
  CHECK(ids == want);
  CHECK(found.size() == want.size());
  CHECK(std::is_sorted(found.begin(), found.end(),
                       [](const auto& a, const auto& b) { return a.id < b.id; }));
  for (const auto& p : found)
    if (p.id == "305") CHECK(p.image == root / "201-400" / "deeper" / "305.img.nii.gz");

  // One split over all of them: with 3+ patients val and test get at least one each, which
  // one split per sub-folder (one patient each) would not give.
  auto patients = found;
  assign_splits(patients, DatasetOptions());
  std::set<std::string> splits;
  for (const auto& p : patients) splits.insert(p.split);
  CHECK(splits == std::set<std::string>{"train", "val", "test"});
}

TEST_CASE("ImageCAS folder: a duplicate id names both files", "[pipeline][input]") {
  const fs::path root = fresh("duplicate");
  touch(root / "1-200" / "7.img.nii.gz");
  touch(root / "copy" / "7.img.nii");
  touch(root / "copy" / "8.img.nii");
  const std::string a = (root / "1-200" / "7.img.nii.gz").string();
  const std::string b = (root / "copy" / "7.img.nii").string();
  CHECK_THROWS_WITH(scan_imagecas_folder(root),
                    Catch::Contains("patient id '7'") && Catch::Contains(a) && Catch::Contains(b));
}

TEST_CASE("ImageCAS folder: none found names the folder and the patterns", "[pipeline][input]") {
  const fs::path root = fresh("none");
  touch(root / "sub" / "1.nii.gz");  // no ".img"
  touch(root / "sub" / "1.label.nii.gz");
  try {
    scan_imagecas_folder(root);
    FAIL("no error");
  } catch (const Error& e) {
    const std::string what = e.what();
    INFO(what);
    CHECK(what.find(root.string()) != std::string::npos);
    for (const auto& ext : volume_extensions()) {
      CHECK(what.find("<id>.img" + ext) != std::string::npos);
      CHECK(what.find("<id>.label" + ext) != std::string::npos);
    }
  }
  CHECK_THROWS_WITH(scan_imagecas_folder(root / "missing"), Catch::Contains("does not exist"));
}
