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
