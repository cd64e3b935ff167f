// Image<T>: row-major storage indexed (row, col); pixel (row i, col j) is data()[i * cols + j].
#include <catch2/catch.hpp>
#include <vector>

#include "gimm/core/image.hpp"

using gimm::Image;

TEST_CASE("Image is row-major and indexed (row, col)", "[core][image]") {
  Image<int> image(3, 5, -1);  // 3 rows, 5 columns
  REQUIRE(image.rows() == 3);
  REQUIRE(image.cols() == 5);
  REQUIRE(image.size() == 15);
  REQUIRE_FALSE(image.empty());
  for (int v : image.storage()) CHECK(v == -1);

  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 5; ++c) image(r, c) = 10 * r + c;
  // Consecutive memory runs along a row: data()[row * cols + col].
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 5; ++c) CHECK(image.data()[r * 5 + c] == 10 * r + c);
  CHECK(image.data()[1] == 1);   // (row 0, col 1), not (row 1, col 0)
  CHECK(image.data()[5] == 10);  // (row 1, col 0)
  CHECK(image(2, 4) == 24);
  CHECK(image.storage().back() == 24);
}

TEST_CASE("Image non-square shapes keep rows and cols apart", "[core][image]") {
  Image<float> tall(7, 2), wide(2, 7);
  CHECK(tall.rows() == 7);
  CHECK(tall.cols() == 2);
  CHECK(wide.rows() == 2);
  CHECK(wide.cols() == 7);
  CHECK(tall.contains(6, 1));
  CHECK_FALSE(tall.contains(1, 6));
  CHECK(wide.contains(1, 6));
  CHECK_FALSE(wide.contains(6, 1));
  wide(1, 6) = 3.5f;
  CHECK(wide.data()[1 * 7 + 6] == 3.5f);
}

TEST_CASE("Image::at checks bounds and names the pixel", "[core][image]") {
  Image<double> image(4, 6, 0.5);
  CHECK(image.at(3, 5) == 0.5);
  CHECK_THROWS_AS(image.at(4, 0), gimm::Error);
  CHECK_THROWS_AS(image.at(0, 6), gimm::Error);
  CHECK_THROWS_AS(image.at(-1, 0), gimm::Error);
  CHECK_THROWS_AS(image.at(0, -1), gimm::Error);
  CHECK_THROWS_WITH(image.at(9, 2), Catch::Matchers::Contains("row 9") &&
                                        Catch::Matchers::Contains("col 2") &&
                                        Catch::Matchers::Contains("4 x 6"));
}

TEST_CASE("Image sizes: empty and negative", "[core][image]") {
  Image<int> none;
  CHECK(none.empty());
  CHECK(none.rows() == 0);
  CHECK(none.cols() == 0);
  CHECK_FALSE(none.contains(0, 0));
  Image<int> zero_rows(0, 4);
  CHECK(zero_rows.empty());
  CHECK_THROWS_AS(Image<int>(-1, 4), gimm::Error);
  CHECK_THROWS_WITH(Image<int>(3, -2), Catch::Matchers::Contains("3 x -2"));
}

TEST_CASE("Image::resize keeps the storage it has room in", "[core][image]") {
  Image<int> im(4, 6, 1);
  const int* storage = im.data();
  im.resize(3, 5);  // smaller: the same memory
  CHECK(im.rows() == 3);
  CHECK(im.cols() == 5);
  CHECK(im.size() == 15u);
  CHECK(im.data() == storage);
  CHECK_FALSE(im.contains(3, 0));
  CHECK(im.contains(2, 4));
  im.resize(6, 4);  // back up to the size it had: still the same memory
  CHECK(im.size() == 24u);
  CHECK(im.data() == storage);
  im.resize(0, 0);
  CHECK(im.empty());
  CHECK_THROWS_WITH(im.resize(2, -3), Catch::Matchers::Contains("2 x -3"));
  CHECK(im.size() == 0u);  // a refused resize leaves the image as it was
  im.assign(5, 4, 9);      // assign: the same storage, every pixel the fill
  CHECK(im.data() == storage);
  CHECK(im.rows() == 5);
  CHECK(im.cols() == 4);
  CHECK(im.storage() == std::vector<int>(20, 9));
  CHECK_THROWS_WITH(im.assign(-1, 2, 0), Catch::Matchers::Contains("-1 x 2"));
  CHECK(im.rows() == 5);
}
