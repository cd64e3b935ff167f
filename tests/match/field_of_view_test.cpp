// The exposed field found in the image (match/field_of_view.hpp): collimator frames of each shape,
// with a penumbra, noise, a soft background and a dark vessel running into the frame, are cut
// away and the field is kept; an image with no frame keeps all of it.
#include <catch2/catch.hpp>
#include <cmath>
#include <functional>

#include "gimm/core/rng.hpp"
#include "gimm/match/field_of_view.hpp"

namespace {

int kSize = 256;  // 512 in the last test: the edges are then found on a reduced copy

/// An angiogram-like frame: a soft background (0.54-0.66), Gaussian noise, a dark vessel running
/// diagonally to the image's edge, and a collimator: `outside(r, c)` is the distance in px past
/// the shutter's edge (<= 0 inside); the frame is 0.12 with a linear penumbra of `penumbra` px.
gimm::Image<float> collimated(const std::function<double(int, int)>& outside, double penumbra,
                              std::uint64_t seed) {
  gimm::Rng rng(seed);
  gimm::Image<float> im(kSize, kSize);
  for (int r = 0; r < kSize; ++r)
    for (int c = 0; c < kSize; ++c) {
      double v = 0.6 + 0.06 * std::sin(r / 40.0) * std::cos(c / 55.0);
      if (std::abs(r - 0.8 * c - 20) < 3) v -= 0.3;  // a vessel, also under the frame
      const double d = outside(r, c);
      const double w = std::clamp(d / penumbra, 0.0, 1.0);  // 0 inside .. 1 fully collimated
      v = (1 - w) * v + w * 0.12;
      im(r, c) = float(std::clamp(v + 0.02 * rng.normal(), 0.0, 1.0));
    }
  return im;
}

/// Share of the truly exposed pixels (outside <= -margin) kept, and number of pixels kept that
/// are in the frame or its penumbra (outside > 0).
std::pair<double, int> score(const gimm::Image<std::uint8_t>& field,
                             const std::function<double(int, int)>& outside, double margin) {
  int exposed = 0, kept = 0, wrong = 0;
  for (int r = 0; r < kSize; ++r)
    for (int c = 0; c < kSize; ++c) {
      const double d = outside(r, c);
      if (d <= -margin) {
        ++exposed;
        kept += field(r, c);
      }
      if (d > 0 && field(r, c)) ++wrong;
    }
  return {double(kept) / exposed, wrong};
}

}  // namespace

TEST_CASE("Field of view: rectangular, octagonal and circular shutters are cut away",
          "[match][field]") {
  const double c0 = (kSize - 1) / 2.0;
  const std::function<double(int, int)> rectangle = [](int r, int c) {
    // 14 px frame on the left, 20 on the right, 10 at the top, none at the bottom
    return std::max({14.0 - c, c - (kSize - 1 - 20.0), 10.0 - r, -1e9});
  };
  const std::function<double(int, int)> octagon = [&](int r, int c) {
    const double x = c - c0, y = r - c0;
    const double side = std::max(std::abs(x), std::abs(y)) - 112;
    const double diagonal = (std::abs(x) + std::abs(y)) / std::sqrt(2.0) - 140;
    return std::max(side, diagonal);
  };
  const std::function<double(int, int)> circle = [&](int r, int c) {
    return std::hypot(r - c0, c - c0) - 115;
  };
  int seed = 1;
  for (const auto& [name, shape] :
       {std::pair{"rectangle", rectangle}, {"octagon", octagon}, {"circle", circle}}) {
    INFO(name);
    const gimm::Image<float> image = collimated(shape, 8, std::uint64_t(seed++));
    const gimm::Image<std::uint8_t> field = gimm::exposed_field(image);
    const auto [kept, wrong] = score(field, shape, 16);
    CHECK(wrong == 0);    // nothing of the frame or its penumbra
    CHECK(kept >= 0.97);  // the field, but for the margin
  }
}

TEST_CASE("Field of view: an image without a collimator keeps its whole field", "[match][field]") {
  const auto nowhere = [](int, int) { return -1e9; };
  const gimm::Image<float> image = collimated(nowhere, 8, 7);
  CHECK(gimm::field_fraction(gimm::exposed_field(image)) == 1.0);
  // A bright border (no collimator, dark anatomy inside) is not a collimator either.
  gimm::Image<float> bright = image;
  for (int r = 0; r < kSize; ++r)
    for (int c = 0; c < 12; ++c) bright(r, c) = 0.95f;
  CHECK(gimm::field_fraction(gimm::exposed_field(bright)) == 1.0);
}

TEST_CASE("Field of view: matches outside a field are dropped; bad options are named",
          "[match][field]") {
  gimm::Image<std::uint8_t> field(10, 10, 1);
  for (int r = 0; r < 10; ++r) field(r, 0) = 0;
  gimm::PairMatches m;
  m.add({5, 5}, {5, 5}, 1);
  m.add({0.2, 5}, {5, 5}, 1);  // A's end on column 0: outside
  m.add({5, 5}, {9.6, 5}, 1);  // B's end off the image: outside
  m.add({1, 5}, {0.4, 5}, 1);  // B's end rounds to column 0: outside
  CHECK(gimm::drop_outside_fields(m, &field, &field) == 3);
  CHECK(m.size() == 1);
  CHECK(gimm::drop_outside_fields(m, nullptr, nullptr) == 0);

  gimm::FieldOfViewOptions o;
  o.directions = 6;
  CHECK_THROWS_WITH(o.validate(), Catch::Contains("directions") && Catch::Contains("6"));
  o = {};
  o.margin_px = std::nan("");
  CHECK_THROWS_WITH(o.validate(), Catch::Contains("margin_px"));
  CHECK_THROWS_WITH(gimm::exposed_field(gimm::Image<float>(8, 300)), Catch::Contains("300 x 8"));
  gimm::Image<std::uint8_t> mask(5, 5, 1);
  CHECK_THROWS_WITH(gimm::clear_outside(mask, field), Catch::Contains("10 x 10"));
}

TEST_CASE("Field of view: at 512 px (found on a reduced copy) the same holds", "[match][field]") {
  kSize = 512;
  const double c0 = (kSize - 1) / 2.0;
  const std::function<double(int, int)> octagon = [&](int r, int c) {
    const double x = c - c0, y = r - c0;
    return std::max(std::max(std::abs(x), std::abs(y)) - 224,
                    (std::abs(x) + std::abs(y)) / std::sqrt(2.0) - 280);
  };
  const std::function<double(int, int)> rectangle = [](int r, int c) {
    return std::max({20.0 - c, c - (kSize - 1 - 9.0), 30.0 - r, r - (kSize - 1 - 12.0)});
  };
  for (const auto& shape : {octagon, rectangle}) {
    const gimm::Image<float> image = collimated(shape, 12, 3);
    const auto [kept, wrong] = score(gimm::exposed_field(image), shape, 20);
    CHECK(wrong == 0);
    CHECK(kept >= 0.97);
  }
  kSize = 256;
}
