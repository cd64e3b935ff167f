// read_volume: the format by the file name, every fixture the same volume, and the errors for
// a folder (a DICOM series) or an unknown name, which must name the formats and how to convert.
#include <catch2/catch.hpp>

#include "gimm/io/volume_file.hpp"
#include "volume_fixtures.hpp"

namespace fs = std::filesystem;

TEST_CASE("read_volume picks the reader by the file name", "[io][volume_file]") {
  using gimm::VolumeFormat;
  CHECK(gimm::volume_format("a/ct.nii.gz") == VolumeFormat::nifti);
  CHECK(gimm::volume_format("ct.nii") == VolumeFormat::nifti);
  CHECK(gimm::volume_format("ct.nrrd") == VolumeFormat::nrrd);
  CHECK(gimm::volume_format("ct.nhdr") == VolumeFormat::nrrd);
  CHECK(gimm::volume_format("ct.mha") == VolumeFormat::metaimage);
  CHECK(gimm::volume_format("ct.mhd") == VolumeFormat::metaimage);
  CHECK(!gimm::volume_format("ct.raw"));
  CHECK(!gimm::volume_format(".mha"));  // an extension alone is no file name
  CHECK(gimm::volume_extension("1.img.nii.gz") == ".nii.gz");
  CHECK(gimm::volume_extension("1.img.nrrd") == ".nrrd");
  for (const char* name : {"source.nii", "ct.nrrd", "ct_nhdr.nhdr", "ct.mha", "ct_mhd.mhd"}) {
    INFO(name);
    CHECK(fixtures::fixture_difference(gimm::read_volume<float>(fixtures::dir() / name)) == "");
    CHECK(fixtures::fixture_difference(gimm::read_volume<std::int16_t>(fixtures::dir() / name)) ==
          "");
  }
}

TEST_CASE("read_volume on a folder or an unknown name names the formats and how to convert",
          "[io][volume_file]") {
  const fs::path folder = fixtures::tmp("dicom_series");
  fs::create_directories(folder);
  for (const fs::path& p : {folder, fixtures::dir() / "ct_nhdr.raw"}) {
    INFO(p.string());
    try {
      (void)gimm::read_volume<float>(p);
      FAIL("no error");
    } catch (const gimm::Error& e) {
      const std::string msg = e.what();
      INFO(msg);
      CHECK_THAT(msg, Catch::Contains(p.string()));
      for (const char* f : {".nii.gz", ".nrrd", ".nhdr", ".mha", ".mhd", "dcm2niix", "plastimatch"})
        CHECK_THAT(msg, Catch::Contains(f));
    }
  }
  CHECK_THROWS_WITH(gimm::read_volume<float>(folder), Catch::Contains("is a folder"));
}

TEST_CASE("Detached data files: anywhere, named when outside, regular files only",
          "[io][volume_file]") {
  // Policy (docs/conventions.md, "Detached data files"): NRRD and MetaImage allow a data file
  // anywhere; gimm reads it, detached_data_note names one outside the header's folder (the CLIs
  // print it), and a folder, device or pipe is refused by name.
  const fs::path home = fixtures::tmp("detached") / "headers";
  fs::create_directories(home / "sub");
  fs::copy_file(fixtures::dir() / "ct_nhdr.raw", home / "sub" / "inside.raw",
                fs::copy_options::overwrite_existing);
  struct Format {
    const char* header;
    const char* key;
    const char* raw;
  };
  for (const Format f : {Format{"ct_nhdr.nhdr", "data file: ", "ct_nhdr.raw"},
                         Format{"ct_mhd.mhd", "ElementDataFile = ", "ct_mhd.raw"}}) {
    const std::string text = fixtures::read_text(fixtures::dir() / f.header);
    const std::string raw = (fixtures::dir() / f.raw).string();
    const std::string ext = fs::path(f.header).extension().string();
    auto header_to = [&](const std::string& name, const std::string& data) {
      const fs::path p = home / (name + ext);
      fixtures::write_text(
          p, fixtures::replaced(text, std::string(f.key) + f.raw, std::string(f.key) + data));
      return p;
    };
    INFO(f.header);
    // Beside (or below) the header: read, no note.
    const fs::path below = header_to("below", "sub/inside.raw");
    CHECK(fixtures::fixture_difference(gimm::read_volume<float>(below)) == "");
    CHECK(gimm::detached_data_note(below).empty());
    CHECK(gimm::volume_data_file(below) == home / "sub" / "inside.raw");
    // Outside: absolute, or climbing out: read, and the note names both files.
    REQUIRE(fs::relative(raw, home).string().rfind("..", 0) == 0);  // climbs out of home
    for (const std::string& data : {raw, fs::relative(raw, home).string()}) {
      const fs::path outside = header_to("outside", data);
      CHECK(fixtures::fixture_difference(gimm::read_volume<float>(outside)) == "");
      const std::string note = gimm::detached_data_note(outside);
      CHECK_THAT(note, Catch::Contains(outside.string()) && Catch::Contains("ct_") &&
                           Catch::Contains("outside its folder"));
    }
    // A device, a folder: refused by name, before a byte is read (/dev/zero streamed forever).
    for (const std::string& data : {std::string("/dev/zero"), home.string()}) {
      const fs::path bad = header_to("device", data);
      CHECK_THROWS_AS(gimm::read_volume<float>(bad), gimm::FormatError);
      CHECK_THROWS_WITH(gimm::read_volume<float>(bad),
                        Catch::Contains(data) && Catch::Contains("not a regular file"));
    }
  }
  // Attached data and NIfTI: the file itself.
  CHECK(gimm::volume_data_file(fixtures::dir() / "ct.nrrd") == fixtures::dir() / "ct.nrrd");
  CHECK(gimm::detached_data_note(fixtures::dir() / "source.nii").empty());
}
