// What the learned matcher's network sees (match/network_input.hpp): the size and padding, and
// the vessel-enhanced input's meaning (dark lines kept, dark steps and bright lines dropped).
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>

#include "gimm/match/network_input.hpp"

namespace {

/// A 64 x 64 angiogram-like image: a dark step (left half darker, as a heart shadow's edge), a
/// vertical dark line 3 px wide at column 40 (a vessel) and a bright line at row 20 (not one).
gimm::Image<float> step_and_lines() {
  gimm::Image<float> image(64, 64);
  for (int r = 0; r < 64; ++r)
    for (int c = 0; c < 64; ++c) {
      float v = c < 24 ? 0.35f : 0.8f;
      if (std::abs(c - 40) <= 1) v *= 0.5f;
      if (r == 20 && c >= 30) v = std::min(1.0f, v + 0.15f);
      image(r, c) = v;
    }
  return image;
}

float at(const gimm::NetworkInput& in, int r, int c) {
  return in.tensor[r * in.tensor.dim(3) + c];
}

}  // namespace

TEST_CASE("network input: intensity is the image, resized and zero-padded to multiples of 8",
          "[match][learned]") {
  gimm::Image<float> image(30, 20);
  for (int r = 0; r < 30; ++r)
    for (int c = 0; c < 20; ++c) image(r, c) = float(r * 20 + c) / 600.0f;
  const auto in = gimm::to_network_input(image, 0, gimm::NetworkImage::intensity, "image A");
  CHECK(in.tensor.shape() == gimm::nn::Shape{1, 1, 32, 24});
  CHECK(in.content_rows == 30);
  CHECK(in.content_cols == 20);
  CHECK(at(in, 29, 19) == image(29, 19));
  CHECK(at(in, 30, 5) == 0.0f);  // padding
  CHECK(at(in, 5, 21) == 0.0f);
  // Halved: the longer side 15, each network pixel the mean of a 2x2 block (exact at factor 2).
  const auto half = gimm::to_network_input(image, 15, gimm::NetworkImage::intensity, "image A");
  CHECK(half.content_rows == 15);
  CHECK(half.content_cols == 10);
  CHECK(half.scale_u == 2.0);
  const float block = (image(2, 4) + image(2, 5) + image(3, 4) + image(3, 5)) / 4;
  CHECK(std::abs(at(half, 1, 2) - block) < 1e-6f);
}

TEST_CASE("network input: vesselness keeps dark lines, drops dark steps and bright lines",
          "[match][learned]") {
  const auto in =
      gimm::to_network_input(step_and_lines(), 0, gimm::NetworkImage::vesselness, "image A");
  REQUIRE(in.tensor.shape() == gimm::nn::Shape{1, 1, 64, 64});
  // The vessel is the darkest thing in the enhanced image (1 - sqrt(V), V = 1 at its strongest).
  CHECK(at(in, 40, 40) < 0.05f);
  CHECK(at(in, 50, 40) < 0.05f);
  // Flat ground either side of the step, the step's edge itself, and the bright line: ~1.
  CHECK(at(in, 50, 10) > 0.9f);
  CHECK(at(in, 50, 55) > 0.9f);
  CHECK(at(in, 50, 23) > 0.8f);
  CHECK(at(in, 50, 24) > 0.8f);
  CHECK(at(in, 20, 50) > 0.8f);
  // In intensities the step is as strong as the vessel: the enhancement is what drops it.
  const auto raw =
      gimm::to_network_input(step_and_lines(), 0, gimm::NetworkImage::intensity, "image A");
  CHECK(at(raw, 50, 10) < at(raw, 50, 40));
}

TEST_CASE("network input: enhanced after resizing, at the network's own resolution",
          "[match][learned]") {
  // The same vessel at 128 px, halved to 64: the enhancement runs on the 64 px image (what
  // tools/train computes from its resized views), so it equals the enhancement of the resize.
  const gimm::Image<float> small = step_and_lines();
  gimm::Image<float> big(128, 128);
  for (int r = 0; r < 128; ++r)
    for (int c = 0; c < 128; ++c) big(r, c) = small(r / 2, c / 2);
  const auto in = gimm::to_network_input(big, 64, gimm::NetworkImage::vesselness, "image B");
  const gimm::Image<float> expected =
      gimm::network_image(gimm::resize_bilinear(big, 64, 64), gimm::NetworkImage::vesselness);
  float worst = 0;
  for (int r = 0; r < 64; ++r)
    for (int c = 0; c < 64; ++c) worst = std::max(worst, std::abs(at(in, r, c) - expected(r, c)));
  CHECK(worst == 0.0f);
  CHECK(in.scale_u == 2.0);
  // A flat image has no structure: all 1, no NaN from the normalisation.
  const gimm::Image<float> flat(16, 16, 0.5f);
  const gimm::Image<float> none = gimm::network_image(flat, gimm::NetworkImage::vesselness);
  for (float v : none.storage()) CHECK(v == 1.0f);
}

TEST_CASE("network input: bad input kinds and pixels are refused, naming them",
          "[match][learned]") {
  CHECK(gimm::network_image_kind("vesselness") == gimm::NetworkImage::vesselness);
  CHECK_THROWS_WITH(gimm::network_image_kind("edges"),
                    Catch::Contains("intensity|vesselness, got 'edges'"));
  gimm::Image<float> image(16, 16, 0.5f);
  image(3, 7) = std::nanf("");
  CHECK_THROWS_WITH(gimm::to_network_input(image, 0, gimm::NetworkImage::vesselness, "image A"),
                    Catch::Contains("image A: pixel (3, 7) is nan"));
}
