// Adam7-interlaced PNGs decode to the same pixels as plain ones (libpng de-interlacing).
#include <png.h>

#include <catch2/catch.hpp>
#include <cstdio>
#include <string>
#include <vector>

#include "gimm/io/png.hpp"

namespace {

void write_interlaced_16(const std::string& path, int rows, int cols) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  REQUIRE(f != nullptr);
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  png_init_io(png, f);
  png_set_IHDR(png, info, cols, rows, 16, PNG_COLOR_TYPE_GRAY, PNG_INTERLACE_ADAM7,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  std::vector<std::vector<png_byte>> data(static_cast<std::size_t>(rows));
  std::vector<png_bytep> pointers;
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const unsigned v = static_cast<unsigned>(r * 1000 + c * 7);  // big-endian samples
      data[std::size_t(r)].push_back(static_cast<png_byte>(v >> 8));
      data[std::size_t(r)].push_back(static_cast<png_byte>(v & 0xff));
    }
    pointers.push_back(data[std::size_t(r)].data());
  }
  png_write_image(png, pointers.data());
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  std::fclose(f);
}

}  // namespace

TEST_CASE("png: Adam7-interlaced files decode to the right pixels", "[io][png]") {
  const std::string path = std::string(GIMM_TEST_TMP) + "/interlaced16.png";
  std::filesystem::create_directories(GIMM_TEST_TMP);
  write_interlaced_16(path, 13, 11);
  const gimm::Image<std::uint16_t> image = gimm::read_png16(path);
  REQUIRE(image.rows() == 13);
  REQUIRE(image.cols() == 11);
  for (int r = 0; r < 13; ++r)
    for (int c = 0; c < 11; ++c) CHECK(image(r, c) == r * 1000 + c * 7);
  const gimm::Image<float> unit = gimm::read_png_unit(path);
  CHECK(unit(12, 10) == Approx((12 * 1000 + 70) / 65535.0));
}
