// PNG (8/16-bit grey, RGB) and NPY round trips, byte layout, and bad-file errors.
#include <zlib.h>
#include <catch2/catch.hpp>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "gimm/io/npy.hpp"
#include "gimm/io/png.hpp"

namespace fs = std::filesystem;

namespace {
fs::path tmp_path(const std::string& name) {
  fs::create_directories(GIMM_TEST_TMP);
  return fs::path(GIMM_TEST_TMP) / name;
}
}  // namespace

TEST_CASE("16-bit PNG round trip is exact, rows are image rows", "[io][png]") {
  gimm::Image<std::uint16_t> image(3, 5);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 5; ++c)
      image(r, c) = static_cast<std::uint16_t>(1000 * r + c + 60000 * (r == 2));
  const auto p = tmp_path("g16.png");
  gimm::write_png(p, image);
  const auto back = gimm::read_png16(p);
  REQUIRE(back.rows() == 3);
  REQUIRE(back.cols() == 5);
  CHECK(back.storage() == image.storage());
  // PNG stores 16-bit samples big-endian: the first sample of row 0 is (0, 0) = 0x0000, the
  // second is 1 = 0x0001. A byte-order flip would read 256.
  CHECK(back(0, 1) == 1);
}

TEST_CASE("8-bit PNG round trip, and 8 <-> 16 bit scaling keeps full scale", "[io][png]") {
  gimm::Image<std::uint8_t> image(4, 2);
  for (std::size_t n = 0; n < image.size(); ++n)
    image.data()[n] = static_cast<std::uint8_t>(37 * n);
  const auto p = tmp_path("g8.png");
  gimm::write_png(p, image);
  CHECK(gimm::read_png8(p).storage() == image.storage());
  CHECK(gimm::read_png16(p)(0, 1) == 37 * 257);
}

TEST_CASE("RGB PNG is read back as grey", "[io][png]") {
  gimm::Image<gimm::Rgb8> image(2, 2, gimm::Rgb8{200, 200, 200});
  image(1, 1) = gimm::Rgb8{0, 0, 0};
  const auto p = tmp_path("rgb.png");
  gimm::write_png(p, image);
  const auto grey = gimm::read_png8(p);
  CHECK(int(grey(0, 0)) == Approx(200).margin(1));
  CHECK(grey(1, 1) == 0);
}

TEST_CASE("PNG errors name the file", "[io][png]") {
  const auto p = tmp_path("not_png.png");
  std::ofstream(p) << "hello";
  CHECK_THROWS_WITH(gimm::read_png16(p),
                    Catch::Contains(p.string()) && Catch::Contains("signature"));
  gimm::Image<std::uint8_t> image(8, 8, 7);
  const auto q = tmp_path("cut.png");
  gimm::write_png(q, image);
  auto bytes = gimm::read_file_bytes(q);
  bytes.resize(bytes.size() / 2);
  std::ofstream(q, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), bytes.size());
  CHECK_THROWS_WITH(gimm::read_png16(q), Catch::Contains(q.string()));
  CHECK_THROWS_WITH(gimm::write_png(tmp_path("empty.png"), gimm::Image<std::uint8_t>()),
                    Catch::Contains("empty"));
  // A folder where a file belongs: it said "error reading" (fopen opens folders on Linux).
  const auto folder = tmp_path("a_folder.png");
  fs::create_directories(folder);
  CHECK_THROWS_WITH(gimm::read_png16(folder),
                    Catch::Contains(folder.string()) && Catch::Contains("is a folder, not a file"));
  // The size libpng refuses to read is said, from the header's own bytes.
  std::vector<unsigned char> wide = gimm::read_file_bytes(q);
  const unsigned char width[4] = {0, 0, 0x9c, 0x40};  // 40000
  std::memcpy(wide.data() + 16, width, 4);
  const auto w = tmp_path("wide.png");
  std::ofstream(w, std::ios::binary).write(reinterpret_cast<const char*>(wide.data()), wide.size());
  CHECK_THROWS_WITH(gimm::read_png16(w), Catch::Contains("header 40000 x 8 px"));
}

TEST_CASE("PNG whose header claims more than its data can hold is refused before allocating",
          "[io][png]") {
  // A valid 1 x 1 16-bit PNG, then its IHDR rewritten to 32768 x 32768 (CRC fixed): libpng
  // would allocate 2 GiB of rows before finding the data missing.
  const auto p = tmp_path("huge_claim.png");
  gimm::write_png(p, gimm::Image<std::uint16_t>(1, 1, 5));
  auto bytes = gimm::read_file_bytes(p);
  const auto put32 = [&](std::size_t at, std::uint32_t v) {
    for (int b = 0; b < 4; ++b) bytes[at + b] = static_cast<unsigned char>(v >> (24 - 8 * b));
  };
  put32(16, 32768);  // width  (IHDR data starts at byte 16)
  put32(20, 32768);  // height
  put32(29, static_cast<std::uint32_t>(crc32(0, bytes.data() + 12, 17)));  // type + data
  std::ofstream(p, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()),
             static_cast<std::streamsize>(bytes.size()));
  CHECK_THROWS_WITH(gimm::read_png16(p), Catch::Contains(p.string()) &&
                                             Catch::Contains("32768 x 32768") &&
                                             Catch::Contains("compressed data can hold"));
}

namespace {
/// A .npy file with the given header dict and `data_bytes` zero bytes of data.
fs::path npy_with_header(const std::string& name, const std::string& dict, std::size_t data_bytes) {
  std::string header = dict;
  while ((10 + header.size() + 1) % 64) header += ' ';
  header += '\n';
  std::string file = std::string("\x93NUMPY\x01\x00", 8);
  file += static_cast<char>(header.size() & 0xff);
  file += static_cast<char>(header.size() >> 8);
  file += header + std::string(data_bytes, '\0');
  const auto p = tmp_path(name);
  std::ofstream(p, std::ios::binary) << file;
  return p;
}
}  // namespace

TEST_CASE("NPY shapes are parsed exactly and checked against the file first", "[io][npy]") {
  const std::string head = "{'descr': '<f4', 'fortran_order': False, 'shape': ";
  // Each was read as another shape before: 1 x 1 (int wrap), 1 x 2 (third extent ignored).
  CHECK_THROWS_WITH(
      gimm::read_npy_image<float>(npy_with_header("wrap.npy", head + "(4294967297, 1), }", 4)),
      Catch::Contains("wrap.npy") && Catch::Contains("4294967297"));
  CHECK_THROWS_WITH(
      gimm::read_npy_image<float>(npy_with_header("3d.npy", head + "(1, 2, 1), }", 8)),
      Catch::Contains("3d.npy") && Catch::Contains("2D shape") && Catch::Contains("(1, 2, 1)"));
  // 40 GB claimed by a 4-byte payload: the size error comes before any allocation.
  CHECK_THROWS_WITH(
      gimm::read_npy_image<float>(npy_with_header("big.npy", head + "(100000, 100000), }", 4)),
      Catch::Contains("big.npy") && Catch::Contains("data size 4 bytes") &&
          Catch::Contains("(100000, 100000)"));
  CHECK_THROWS_WITH(gimm::read_npy_image<float>(npy_with_header("neg.npy", head + "(-1, 2), }", 0)),
                    Catch::Contains("not a tuple of integers"));
  CHECK_THROWS_WITH(gimm::read_npy_image<float>(npy_with_header("one.npy", head + "(4,), }", 16)),
                    Catch::Contains("2D shape"));
  // The exact form is still read.
  // Found by libFuzzer (UBSan: memcpy from a null buffer): an empty shape is refused by name.
  CHECK_THROWS_WITH(
      gimm::read_npy_image<float>(npy_with_header("empty.npy", head + "(0, 6), }", 0)),
      Catch::Contains("empty.npy") && Catch::Contains("(0, 6) has no pixels"));
  CHECK_THROWS_WITH(
      gimm::read_npy_image<float>(npy_with_header("empty2.npy", head + "(3, 0), }", 0)),
      Catch::Contains("(3, 0) has no pixels"));
  const auto ok = gimm::read_npy_image<float>(npy_with_header("ok.npy", head + "(2, 3), }", 24));
  CHECK((ok.rows() == 2 && ok.cols() == 3));
}

TEST_CASE("NPY float image: exact header bytes and round trip", "[io][npy]") {
  gimm::Image<float> image(2, 3);
  for (std::size_t n = 0; n < image.size(); ++n) image.data()[n] = 0.5f * n;
  const auto p = tmp_path("x.npy");
  gimm::write_npy(p, image);
  const auto bytes = gimm::read_file_bytes(p);
  REQUIRE(bytes.size() == 128 + 6 * 4);  // header padded to 128 bytes
  const std::string header(bytes.begin() + 10, bytes.begin() + 128);
  CHECK(header.rfind("{'descr': '<f4', 'fortran_order': False, 'shape': (2, 3), }", 0) == 0);
  CHECK(header.back() == '\n');
  float third;
  std::memcpy(&third, bytes.data() + 128 + 2 * 4, 4);
  CHECK(third == 1.0f);  // (row 0, col 2): C order
  const auto back = gimm::read_npy_image<float>(p);
  CHECK(back.rows() == 2);
  CHECK(back.storage() == image.storage());
  CHECK_THROWS_WITH(gimm::read_npy_image<double>(p), Catch::Contains("element type"));
}
