// draw_text: glyph pixels where the font puts them, scaling, clipping, refused characters.
#include <catch2/catch.hpp>
#include <cstdint>
#include <string>
#include <vector>

#include "gimm/core/bitmap_text.hpp"

namespace {

/// The image as rows of '#' (drawn) and '.', for comparison with a glyph drawn by hand.
std::vector<std::string> rows_of(const gimm::Image<std::uint8_t>& image) {
  std::vector<std::string> out;
  for (int r = 0; r < image.rows(); ++r) {
    std::string line;
    for (int c = 0; c < image.cols(); ++c) line += image(r, c) ? '#' : '.';
    out.push_back(line);
  }
  return out;
}

}  // namespace

TEST_CASE("draw_text puts the font's pixels where the glyph has them", "[core][text]") {
  gimm::Image<std::uint8_t> image(7, 11, 0);
  gimm::draw_text(image, 0, 0, "A1", std::uint8_t{1});
  // By hand: A, a blank spacing column, 1.
  const std::vector<std::string> expected = {
      ".###....#..",  //
      "#...#..##..",  //
      "#...#...#..",  //
      "#####...#..",  //
      "#...#...#..",  //
      "#...#...#..",  //
      "#...#..###.",
  };
  CHECK(rows_of(image) == expected);
  // Lower case is drawn as upper case.
  gimm::Image<std::uint8_t> lower(7, 11, 0);
  gimm::draw_text(lower, 0, 0, "a1", std::uint8_t{1});
  CHECK(rows_of(lower) == expected);
  CHECK(gimm::text_width("A1") == 11);
  CHECK(gimm::text_width("A1", 3) == 33);
  CHECK(gimm::text_height(2) == 14);
}

TEST_CASE("draw_text scales each font pixel to a block and clips at the border", "[core][text]") {
  gimm::Image<std::uint8_t> image(14, 10, 0);
  gimm::draw_text(image, 0, 0, "-", std::uint8_t{9}, 2);
  // '-' is row 3 of the glyph, columns 0-4: rows 6-7, columns 0-9 at scale 2.
  for (int r = 0; r < 14; ++r)
    for (int c = 0; c < 10; ++c) CHECK(image(r, c) == ((r == 6 || r == 7) ? 9 : 0));
  // Partly or wholly outside: no write out of bounds, the inside part drawn.
  gimm::Image<std::uint8_t> small(4, 4, 0);
  gimm::draw_text(small, -3, -2, "HELLO WORLD 0123456789", std::uint8_t{1}, 3);
  gimm::draw_text(small, 100, 100, "X", std::uint8_t{1});
  int lit = 0;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) lit += small(r, c);
  CHECK(lit > 0);
}

TEST_CASE("draw_text refuses what it has no glyph for, naming it", "[core][text]") {
  gimm::Image<std::uint8_t> image(7, 20, 0);
  CHECK_THROWS_WITH(gimm::draw_text(image, 0, 0, "A~B", std::uint8_t{1}),
                    Catch::Contains("'~'") && Catch::Contains("A~B"));
  CHECK_THROWS_WITH(gimm::draw_text(image, 0, 0, "A", std::uint8_t{1}, 0),
                    Catch::Contains("scale"));
}
