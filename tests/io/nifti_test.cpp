// NIfTI-1: round trips for every stored type, RAS <-> LPS, sform/qform/pixdim precedence,
// scaling, byte order, and every malformed-file error naming the file.
#include <catch2/catch.hpp>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "gimm/io/nifti.hpp"

// Its own namespace: the tests are compiled as one file (tests/CMakeLists.txt).
namespace nifti_test {

namespace fs = std::filesystem;

namespace {

fs::path tmp_path(const std::string& name) {
  fs::create_directories(GIMM_TEST_TMP);
  return fs::path(GIMM_TEST_TMP) / name;
}

gimm::VolumeGeometry oblique_geometry() {
  gimm::VolumeGeometry g;
  g.dims = {5, 4, 3};
  g.spacing = {0.4, 0.5, 1.25};
  g.origin = {-12.5, 30.25, 101.0};
  g.direction = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  return g;
}

template <class T>
gimm::Volume<T> ramp(const gimm::VolumeGeometry& g) {
  gimm::Volume<T> v(g);
  for (std::size_t n = 0; n < v.size(); ++n)
    v.data()[n] = static_cast<T>(int(n % 97) - 10 * (n % 2));
  return v;
}

void write_bytes(const fs::path& p, const std::vector<unsigned char>& bytes) {
  std::ofstream(p, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), bytes.size());
}

std::vector<unsigned char> valid_file_bytes() {
  gimm::Volume<std::int16_t> v = ramp<std::int16_t>(oblique_geometry());
  const auto p = tmp_path("valid.nii");
  gimm::write_nifti(p, v);
  return gimm::read_file_bytes(p);
}

template <class T>
void patch(std::vector<unsigned char>& bytes, std::size_t offset, T value) {
  std::memcpy(bytes.data() + offset, &value, sizeof(T));
}

void require_format_error(const std::vector<unsigned char>& bytes, const std::string& name,
                          const std::string& fragment) {
  const auto p = tmp_path(name);
  write_bytes(p, bytes);
  try {
    (void)gimm::read_nifti<float>(p);
    FAIL("no error for " << name);
  } catch (const gimm::FormatError& e) {
    const std::string message = e.what();
    INFO(message);
    CHECK(message.find(p.string()) != std::string::npos);
    CHECK(message.find(fragment) != std::string::npos);
  }
}

}  // namespace

TEMPLATE_TEST_CASE("NIfTI round trip keeps voxels and geometry", "[io][nifti]", std::uint8_t,
                   std::int8_t, std::int16_t, std::uint16_t, std::int32_t, std::uint32_t, float,
                   double) {
  const auto g = oblique_geometry();
  const auto v = ramp<TestType>(g);
  for (const char* name : {"round.nii", "round.nii.gz"}) {
    const auto p = tmp_path(name);
    gimm::write_nifti(p, v);
    const auto back = gimm::read_nifti<TestType>(p);
    REQUIRE(back.dims() == g.dims);
    CHECK(back.storage() == v.storage());
    CHECK((back.spacing() - g.spacing).norm() < 1e-6);
    CHECK((back.origin() - g.origin).norm() < 1e-4);
    CHECK((back.direction() - g.direction).norm() < 1e-6);
    CHECK(gimm::read_nifti_header(p).affine_source == "sform");
  }
}

TEST_CASE("NIfTI from memory equals the file read, gzipped or not, and names the bytes",
          "[io][nifti]") {
  const auto v = ramp<float>(oblique_geometry());
  for (const char* name : {"memory.nii", "memory.nii.gz"}) {
    const auto p = tmp_path(name);
    gimm::write_nifti(p, v);
    const auto from_file = gimm::read_nifti<float>(p);
    const auto from_memory = gimm::nifti_from_bytes<float>(gimm::read_file_bytes(p), "buffer");
    CHECK(from_memory.storage() == from_file.storage());
    CHECK(from_memory.geometry().dims == from_file.geometry().dims);
    CHECK((from_memory.origin() - from_file.origin()).norm() == 0);
    CHECK((from_memory.direction() - from_file.direction()).norm() == 0);
  }
  // Compression is told by the bytes, not the name (docs/conventions.md): a plain file named
  // .nii.gz and a gzipped one named .nii read as the same volume.
  std::filesystem::copy_file(tmp_path("memory.nii"), tmp_path("plain.nii.gz"),
                             std::filesystem::copy_options::overwrite_existing);
  std::filesystem::copy_file(tmp_path("memory.nii.gz"), tmp_path("packed.nii"),
                             std::filesystem::copy_options::overwrite_existing);
  CHECK(gimm::read_nifti<float>(tmp_path("plain.nii.gz")).storage() == v.storage());
  CHECK(gimm::read_nifti<float>(tmp_path("packed.nii")).storage() == v.storage());
  std::vector<unsigned char> bytes = valid_file_bytes();
  bytes.resize(400);  // the header promises 60 int16 voxels after byte 352
  try {
    (void)gimm::nifti_from_bytes<float>(bytes, "my buffer");
    FAIL("no error for truncated bytes");
  } catch (const gimm::FormatError& e) {
    CHECK(std::string(e.what()).find("my buffer") != std::string::npos);
  }
}

TEST_CASE("NIfTI stores RAS: LPS +x (patient left) is stored as -x", "[io][nifti]") {
  gimm::VolumeGeometry g;
  g.dims = {2, 2, 2};
  g.spacing = {1, 2, 3};
  g.origin = {10, 20, 30};  // LPS: 10 mm left, 20 mm posterior, 30 mm superior
  const auto p = tmp_path("ras.nii");
  gimm::write_nifti(p, gimm::Volume<float>(g, 1.0f));
  const auto bytes = gimm::read_file_bytes(p);
  auto f = [&](std::size_t off) {
    float x;
    std::memcpy(&x, bytes.data() + off, 4);
    return x;
  };
  // srow_x = (-1, 0, 0, -10): i runs towards patient left = RAS -x; origin is 10 mm left.
  CHECK(f(280) == -1.0f);
  CHECK(f(292) == -10.0f);
  CHECK(f(296 + 4) == -2.0f);  // srow_y[1]
  CHECK(f(296 + 12) == -20.0f);
  CHECK(f(312 + 8) == 3.0f);  // srow_z[2]
  CHECK(f(312 + 12) == 30.0f);
  // qform: the flip of x and y is a rotation by pi about z: quaternion (b, c, d) = (0, 0, 1).
  CHECK(f(256) == Approx(0).margin(1e-7));
  CHECK(f(264) == Approx(1));
  CHECK(f(268) == -10.0f);
}

TEST_CASE("NIfTI reader takes the qform when there is no sform, pixdim when neither",
          "[io][nifti]") {
  auto bytes = valid_file_bytes();
  const auto g = oblique_geometry();
  patch<std::int16_t>(bytes, 254, 0);  // sform_code = 0 -> qform
  auto p = tmp_path("qform.nii");
  write_bytes(p, bytes);
  auto v = gimm::read_nifti<float>(p);
  CHECK(gimm::read_nifti_header(p).affine_source == "qform");
  CHECK((v.direction() - g.direction).norm() < 1e-6);
  CHECK((v.origin() - g.origin).norm() < 1e-4);

  // A left-handed grid (third axis flipped) goes through qfac = -1.
  auto lh = g;
  lh.direction.col(2) *= -1;
  p = tmp_path("qform_lh.nii");
  gimm::write_nifti(p, gimm::Volume<float>(lh, 2.0f));
  bytes = gimm::read_file_bytes(p);
  patch<std::int16_t>(bytes, 254, 0);
  write_bytes(p, bytes);
  v = gimm::read_nifti<float>(p);
  CHECK((v.direction() - lh.direction).norm() < 1e-6);

  // A quaternion that is no rotation (b^2 + c^2 + d^2 > 1) is refused, naming the values;
  // float rounding of a unit one (a = 0, b^2 + c^2 + d^2 = 1 + 1e-6) is not.
  auto bad = bytes;
  patch<float>(bad, 256, 0.7f);
  patch<float>(bad, 260, 0.7f);
  patch<float>(bad, 264, 0.7f);
  const auto pbad = tmp_path("qform_not_rotation.nii");
  write_bytes(pbad, bad);
  CHECK_THROWS_WITH(
      gimm::read_nifti<float>(pbad),
      Catch::Contains("qform_not_rotation.nii") && Catch::Contains("(b, c, d) = (0.7, 0.7, 0.7)") &&
          Catch::Contains("b^2 + c^2 + d^2 = 1.47") && Catch::Contains("not a rotation"));
  patch<float>(bad, 256, 0.0f);
  patch<float>(bad, 260, 0.0f);
  patch<float>(bad, 264, 1.000001f);
  write_bytes(pbad, bad);
  CHECK_NOTHROW(gimm::read_nifti<float>(pbad));

  patch<std::int16_t>(bytes, 252, 0);  // qform_code = 0 too -> pixdim only, RAS axes
  write_bytes(p, bytes);
  v = gimm::read_nifti<float>(p);
  CHECK(gimm::read_nifti_header(p).affine_source == "pixdim");
  CHECK((v.direction() - Eigen::Vector3d(-1, -1, 1).asDiagonal().toDenseMatrix()).norm() < 1e-12);
  CHECK(v.origin().norm() == 0);
}

TEST_CASE("NIfTI scl_slope/scl_inter are applied; integer reads refuse non-integers",
          "[io][nifti]") {
  auto bytes = valid_file_bytes();  // int16 ramp
  patch<float>(bytes, 112, 2.0f);
  patch<float>(bytes, 116, -1024.0f);
  const auto p = tmp_path("scaled.nii");
  write_bytes(p, bytes);
  const auto raw = ramp<std::int16_t>(oblique_geometry());
  const auto hu = gimm::read_nifti<float>(p);
  for (std::size_t n = 0; n < raw.size(); ++n)
    REQUIRE(hu.data()[n] == 2.0f * raw.data()[n] - 1024.0f);
  const auto as_int = gimm::read_nifti<std::int32_t>(p);
  CHECK(as_int.data()[3] == 2 * raw.data()[3] - 1024);
  // -1024 and below does not fit uint8: an error naming the voxel, never a clamp.
  CHECK_THROWS_WITH(gimm::read_nifti<std::uint8_t>(p), Catch::Contains("does not fit"));
  patch<float>(bytes, 112, 0.5f);
  patch<float>(bytes, 116, 0.0f);
  write_bytes(p, bytes);
  CHECK_THROWS_WITH(gimm::read_nifti<std::int16_t>(p), Catch::Contains("voxel 1 has value"));
  patch<float>(bytes, 112, 0.0f);  // slope 0 means no scaling
  write_bytes(p, bytes);
  CHECK(gimm::read_nifti<std::int16_t>(p).storage() == raw.storage());
}

TEST_CASE("NIfTI big-endian files read the same", "[io][nifti]") {
  const auto g = oblique_geometry();
  const auto v = ramp<std::int16_t>(g);
  auto bytes = valid_file_bytes();
  auto swap = [&](std::size_t off, int n) {
    std::reverse(bytes.begin() + off, bytes.begin() + off + n);
  };
  swap(0, 4);
  for (std::size_t off = 40; off < 56; off += 2) swap(off, 2);
  for (std::size_t off : {70, 72, 252, 254}) swap(off, 2);
  for (std::size_t off = 76; off < 108; off += 4) swap(off, 4);
  for (std::size_t off : {108, 112, 116}) swap(off, 4);
  for (std::size_t off = 256; off < 328; off += 4) swap(off, 4);
  for (std::size_t off = 352; off < bytes.size(); off += 2) swap(off, 2);
  const auto p = tmp_path("big_endian.nii");
  write_bytes(p, bytes);
  const auto back = gimm::read_nifti<std::int16_t>(p);
  CHECK(back.storage() == v.storage());
  CHECK((back.direction() - g.direction).norm() < 1e-6);
}

TEST_CASE("NIfTI malformed files give errors naming the file and the problem", "[io][nifti]") {
  const auto good = valid_file_bytes();
  auto b = good;
  std::memcpy(b.data() + 344, "xyz\0", 4);
  require_format_error(b, "bad_magic.nii", "bad NIfTI-1 magic");
  b = good;
  patch<std::int32_t>(b, 0, 12345);
  require_format_error(b, "bad_sizeof.nii", "not a NIfTI-1 file");
  // NIfTI-2 (sizeof_hdr 540) in this host's byte order and swapped: both get the hint.
  b = good;
  patch<std::int32_t>(b, 0, 540);
  require_format_error(b, "nifti2_native.nii", "it is a NIfTI-2 file");
  b = good;
  patch<std::int32_t>(b, 0, 0x1c020000);  // 540 = 0x0000021c with its bytes reversed
  require_format_error(b, "nifti2_swapped.nii", "it is a NIfTI-2 file");
  b = good;
  b.resize(b.size() - 7);
  require_format_error(b, "truncated.nii", "truncated");
  b = good;
  b.resize(200);
  require_format_error(b, "short.nii", "too short");
  b = good;
  b.push_back(0);
  require_format_error(b, "long.nii", "do not match the data size");
  b = good;
  patch<std::int16_t>(b, 42, 0);
  require_format_error(b, "zero_dim.nii", "dim[1] must be >= 1, got 0");
  b = good;
  patch<std::int16_t>(b, 42, -5);
  require_format_error(b, "negative_dim.nii", "got -5");
  b = good;
  patch<std::int16_t>(b, 40, 4);
  patch<std::int16_t>(b, 48, 7);
  require_format_error(b, "four_d.nii", "only 3D volumes");
  b = good;
  patch<std::int16_t>(b, 70, 128);  // RGB24
  require_format_error(b, "rgb.nii", "unsupported NIfTI datatype 128");
  b = good;
  patch<std::int16_t>(b, 72, 32);
  require_format_error(b, "bitpix.nii", "bitpix 32");
  b = good;
  patch<std::int16_t>(b, 254, 0);
  patch<float>(b, 80, 0.0f);
  require_format_error(b, "zero_spacing.nii", "pixdim[1]");
  b = good;
  patch<std::int16_t>(b, 254, 0);
  patch<float>(b, 84, std::nanf(""));
  require_format_error(b, "nan_spacing.nii", "pixdim[2]");
  b = good;
  patch<float>(b, 280, std::nanf(""));
  require_format_error(b, "nan_sform.nii", "non-finite");
  b = good;
  for (std::size_t off : {280, 296, 312}) patch<float>(b, off, 0.0f);
  require_format_error(b, "zero_sform.nii", "voxel spacing 0");
  b = good;
  patch<float>(b, 284, 0.9f);  // shear: not orthonormal
  require_format_error(b, "shear.nii", "not orthonormal");
  b = good;
  std::memcpy(b.data() + 344, "ni1\0", 4);
  require_format_error(b, "two_file.nii", ".hdr/.img");

  // A gzip file cut short.
  auto gz = gimm::gzip_compress(good.data(), good.size());
  gz.resize(gz.size() / 2);
  require_format_error(gz, "truncated.nii.gz", "truncated");
  // A gzip bomb: a small header's worth of dims followed by 64 MiB of zeros. Inflating stops
  // just past the size the header implies (found before the fix: the whole stream was inflated,
  // 3 GB peak for a 1 GiB bomb, then "bytes beyond the voxel data").
  auto bomb = good;
  bomb.resize(bomb.size() + (64u << 20), 0);
  gz = gimm::gzip_compress(bomb.data(), bomb.size());
  CHECK(gz.size() < (1u << 20));
  require_format_error(gz, "bomb.nii.gz", "the header implies " + std::to_string(good.size()));
  // A stream cut inside the header.
  gz = gimm::gzip_compress(good.data(), good.size());
  require_format_error(std::vector<unsigned char>(gz.begin(), gz.begin() + 20), "head.nii.gz",
                       "too short");
  CHECK_THROWS_AS(gimm::read_nifti<float>(tmp_path("does_not_exist.nii")), gimm::IoError);
}

TEST_CASE("NIfTI writes are atomic and deterministic", "[io][nifti]") {
  const auto v = ramp<float>(oblique_geometry());
  const auto a = tmp_path("det_a.nii.gz"), b = tmp_path("det_b.nii.gz");
  gimm::write_nifti(a, v);
  gimm::write_nifti(b, v);
  CHECK(gimm::read_file_bytes(a) == gimm::read_file_bytes(b));
  for (const auto& entry : fs::directory_iterator(GIMM_TEST_TMP))
    CHECK(entry.path().string().find(".tmp.") == std::string::npos);
  CHECK_THROWS_AS(gimm::write_nifti(fs::path(GIMM_TEST_TMP) / "no_such_dir" / "x.nii", v),
                  gimm::IoError);
}

}  // namespace nifti_test
