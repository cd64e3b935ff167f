// PNG (8/16-bit grey, RGB) and NPY round trips, byte layout, and bad-file errors.
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
