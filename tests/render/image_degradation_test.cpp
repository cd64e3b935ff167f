// Blur and dose noise applied to rendered angiograms (render/image_degradation.hpp): the noise
// has the Poisson mean and variance, the blur is the shared Gaussian, and both are deterministic.
#include <array>
#include <catch2/catch.hpp>
#include <cmath>
#include <utility>

#include "gimm/render/image_degradation.hpp"

TEST_CASE("Poisson draws have the right mean and variance on both branches", "[render][noise]") {
  gimm::Rng rng(3);
  for (double mean : {0.5, 4.0, 25.0, 200.0, 5000.0}) {
    const int n = 20000;
    double sum = 0, sum2 = 0;
    for (int k = 0; k < n; ++k) {
      const double x = gimm::poisson_draw(mean, rng);
      REQUIRE(x >= 0);
      REQUIRE(x == std::round(x));
      sum += x;
      sum2 += x * x;
    }
    const double m = sum / n, var = sum2 / n - m * m;
    INFO("mean " << mean << ": sample mean " << m << ", variance " << var);
    // 5 standard errors of the mean; the variance within 6%.
    CHECK(std::abs(m - mean) < 5 * std::sqrt(mean / n));
    CHECK(var == Approx(mean).epsilon(0.06));
  }
  CHECK(gimm::poisson_draw(0.0, rng) == 0.0);
}

TEST_CASE("Dose noise: relative noise 1 / sqrt(photons x value), deterministic",
          "[render][noise]") {
  gimm::Image<float> image(64, 64, 0.5f);
  for (int c = 32; c < 64; ++c)
    for (int r = 0; r < 64; ++r) image(r, c) = 0.9f;
  gimm::ImageDegradation d;
  d.photons = 1000;
  gimm::Rng rng(1), again(1);
  const gimm::Image<float> noisy = gimm::degrade_image(image, d, rng);
  CHECK(noisy.storage() == gimm::degrade_image(image, d, again).storage());
  const std::array<std::pair<int, double>, 2> halves = {{{0, 0.5}, {32, 0.9}}};
  for (const auto& [c0, value] : halves) {
    double sum = 0, sum2 = 0;
    for (int r = 0; r < 64; ++r)
      for (int c = c0; c < c0 + 32; ++c) {
        sum += noisy(r, c);
        sum2 += noisy(r, c) * noisy(r, c);
      }
    const double n = 64 * 32, m = sum / n, sd = std::sqrt(sum2 / n - m * m);
    INFO("value " << value << ": mean " << m << ", sd " << sd);
    CHECK(m == Approx(value).margin(0.003));
    CHECK(sd == Approx(std::sqrt(value / d.photons)).epsilon(0.08));
  }
  // Nothing asked, nothing changed; values stay in [0, 1].
  gimm::Rng unused(0);
  CHECK(gimm::degrade_image(image, {}, unused).storage() == image.storage());
  d.photons = 1;
  const gimm::Image<float> dark = gimm::degrade_image(image, d, rng);
  for (float v : dark.storage()) CHECK((v >= 0 && v <= 1));
}

TEST_CASE("Blur: a step edge spreads by sigma; bad settings are named", "[render][noise]") {
  gimm::Image<float> step(16, 64, 0.0f);
  for (int r = 0; r < 16; ++r)
    for (int c = 32; c < 64; ++c) step(r, c) = 1.0f;
  gimm::ImageDegradation d;
  d.blur_px = 2.0;
  gimm::Rng rng(0);
  const gimm::Image<float> blurred = gimm::degrade_image(step, d, rng);
  // The edge sits between pixels 31 and 32: the Gaussian CDF at 0.5 px and at 2.5 px (the
  // sampled kernel is within 2.4e-3 of the continuous one there).
  CHECK(blurred(8, 32) == Approx(0.5 + 0.5 * std::erf(0.5 / (2.0 * std::sqrt(2.0)))).margin(2e-3));
  CHECK(blurred(8, 34) == Approx(0.5 + 0.5 * std::erf(2.5 / (2.0 * std::sqrt(2.0)))).margin(4e-3));
  CHECK(blurred(8, 0) == Approx(0.0).margin(1e-6));
  d.blur_px = -1;
  CHECK_THROWS_WITH(gimm::degrade_image(step, d, rng),
                    Catch::Contains("blur") && Catch::Contains("-1"));
  d.blur_px = 0;
  d.photons = 0.5;
  CHECK_THROWS_WITH(gimm::degrade_image(step, d, rng),
                    Catch::Contains("photons") && Catch::Contains("0.5"));
}
