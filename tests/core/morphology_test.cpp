// Grey morphology: the van Herk / Gil-Werman running extremes against a plain window scan, and
// what the black top-hat keeps (narrow dark bars) and drops (wide bars, steps).
#include <catch2/catch.hpp>
#include <random>

#include "gimm/core/morphology.hpp"

namespace {

/// The slow reference: every window scanned, clipped to the image.
gimm::Image<float> plain_extreme(const gimm::Image<float>& in, int width, bool max) {
  const int half = width / 2;
  gimm::Image<float> out(in.rows(), in.cols());
  for (int r = 0; r < in.rows(); ++r)
    for (int c = 0; c < in.cols(); ++c) {
      float best = in(r, c);
      for (int rr = std::max(0, r - half); rr <= std::min(in.rows() - 1, r + half); ++rr)
        for (int cc = std::max(0, c - half); cc <= std::min(in.cols() - 1, c + half); ++cc)
          best = max ? std::max(best, in(rr, cc)) : std::min(best, in(rr, cc));
      out(r, c) = best;
    }
  return out;
}

gimm::Image<float> random_image(int rows, int cols, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  gimm::Image<float> im(rows, cols);
  for (float& x : im.storage()) x = u(rng);
  return im;
}

}  // namespace

TEST_CASE("Running extremes equal a plain window scan", "[core][morphology]") {
  // Sizes around the block width, windows wider than the image, width 1 (the identity).
  for (const auto& [rows, cols] :
       {std::pair{1, 1}, std::pair{7, 13}, std::pair{20, 9}, std::pair{33, 31}}) {
    const gimm::Image<float> im = random_image(rows, cols, static_cast<unsigned>(rows * cols));
    for (int width : {1, 3, 5, 7, 9, 15, 41}) {
      INFO(rows << " x " << cols << ", width " << width);
      CHECK(gimm::grey_dilate(im, width).storage() == plain_extreme(im, width, true).storage());
      CHECK(gimm::grey_erode(im, width).storage() == plain_extreme(im, width, false).storage());
    }
  }
  const gimm::Image<float> im = random_image(5, 5, 1);
  CHECK_THROWS_WITH(gimm::grey_dilate(im, 4), Catch::Contains("odd") && Catch::Contains("4"));
  CHECK_THROWS_WITH(gimm::grey_erode(im, 0), Catch::Contains("got 0"));
}

TEST_CASE("Black top-hat keeps dark bars narrower than the window, not wide ones or steps",
          "[core][morphology]") {
  // Bright ground 1; a dark bar 3 px wide (depth 0.4), one 11 px wide (depth 0.4), and a step
  // down to 0.5 on the right: with a 7 px window only the narrow bar is kept, at its depth.
  gimm::Image<float> im(24, 60, 1.0f);
  for (int r = 0; r < im.rows(); ++r) {
    for (int c = 10; c < 13; ++c) im(r, c) = 0.6f;
    for (int c = 25; c < 36; ++c) im(r, c) = 0.6f;
    for (int c = 45; c < 60; ++c) im(r, c) = 0.5f;
  }
  const gimm::Image<float> t = gimm::black_top_hat(im, 7);
  for (float x : t.storage()) CHECK(x >= 0.0f);  // a closing is never below its input
  for (int r = 0; r < im.rows(); ++r)
    for (int c = 0; c < im.cols(); ++c) {
      INFO("row " << r << ", col " << c);
      CHECK(t(r, c) == Approx(c >= 10 && c < 13 ? 0.4 : 0.0).margin(1e-6));
    }
  // A window narrower than the bar does not fill it.
  const gimm::Image<float> narrow = gimm::black_top_hat(im, 3);
  CHECK(narrow(5, 11) == 0.0f);
}
