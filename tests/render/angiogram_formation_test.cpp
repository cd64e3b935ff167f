// Image formation (render/iodine.hpp, render/collimator.hpp, render/angiogram_formation.hpp):
// the iodine table and its K edge, the chain's physics step by step, a 3 mm iodinated vessel in
// a water slab measured as clinical frames are measured (contrast, noise, CNR), determinism,
// shutters, validation, the JSON record and domain randomisation.
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <vector>

#include "gimm/dataset/formation_json.hpp"
#include "gimm/render/angiogram_formation.hpp"

using namespace gimm;

namespace {

constexpr int kRows = 256, kCols = 256;
constexpr double kPixelMm = 0.5;                   // detector pixel (gimm's default)
constexpr double kMagnification = 1000.0 / 750.0;  // SID / SOD (gimm's defaults)
constexpr int kVesselCol = 160;                    // the vessel's axis, a vertical line
constexpr double kSlabMm = 200;                    // water a chest-sized patient holds

/// Line integrals of a kSlabMm water slab holding a vertical cylinder of iodinated blood
/// (diameter `diameter_mm` at the isocentre, magnified on the detector) with contrast `c`; each
/// pixel integrates the intensity of 16 sub-columns (partial volume
/// as a detector sees it).
Image<float> slab_with_vessel(const IodineContrast& c = {}, double diameter_mm = 3.0) {
  const double mu_water = water_mu_per_mm(c.effective_kev), mu_lumen = c.lumen_mu_per_mm();
  const double r = diameter_mm / 2;
  Image<float> out(kRows, kCols);
  for (int c = 0; c < kCols; ++c) {
    double intensity = 0;
    for (int k = 0; k < 16; ++k) {
      const double x = (c - 0.5 + (k + 0.5) / 16 - kVesselCol) * kPixelMm / kMagnification;
      const double chord = std::abs(x) < r ? 2 * std::sqrt(r * r - x * x) : 0.0;
      intensity += std::exp(-(mu_water * (kSlabMm - chord) + mu_lumen * chord)) / 16;
    }
    for (int r0 = 0; r0 < kRows; ++r0) out(r0, c) = static_cast<float>(-std::log(intensity));
  }
  return out;
}

double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(v.size() / 2), v.end());
  return v[v.size() / 2];
}

struct Measured {
  double contrast, noise, cnr;
};

/// As clinical frames are measured: contrast = median of a background ring (10-20 px from the
/// axis, both sides) minus the median on the vessel's centreline (rows 64-191); noise = the std
/// of the high-pass image minus its 3x3 mean, times sqrt(9/8) (white noise keeps 8/9 of its
/// variance through that high-pass), in a flat patch 40 px and more from the vessel.
Measured measure(const Image<float>& image) {
  std::vector<double> centre, ring;
  for (int r = 64; r < 192; ++r) {
    centre.push_back(image(r, kVesselCol));
    for (int d = 10; d <= 20; ++d) {
      ring.push_back(image(r, kVesselCol - d));
      ring.push_back(image(r, kVesselCol + d));
    }
  }
  double sum = 0, sum2 = 0;
  int n = 0;
  for (int r = 41; r < 100; ++r)
    for (int c = 31; c < 100; ++c) {
      double mean3 = 0;
      for (int dr = -1; dr <= 1; ++dr)
        for (int dc = -1; dc <= 1; ++dc) mean3 += image(r + dr, c + dc) / 9.0;
      const double h = image(r, c) - mean3;
      sum += h;
      sum2 += h * h;
      ++n;
    }
  Measured m;
  m.contrast = median(ring) - median(centre);
  m.noise = std::sqrt(std::max(sum2 / n - (sum / n) * (sum / n), 0.0)) * std::sqrt(9.0 / 8.0);
  m.cnr = m.noise > 0 ? m.contrast / m.noise : std::numeric_limits<double>::infinity();
  return m;
}

/// The chain with every step but the one under test switched off.
AngiogramFormation bare() {
  AngiogramFormation f;
  f.scatter_to_primary = 0;
  f.focal_spot_blur_px = f.detector_blur_px = 0;
  f.detector_photons = 0;
  f.electronic_noise = 0;
  f.range_compression = 0;
  f.edge_gain = 0;
  f.window = WindowMode::fixed;
  f.window_high_percentile = 100;
  f.window_width = 1.0;
  f.bits = 0;
  f.shutter.shape = ShutterShape::none;
  f.display_black = 0;
  f.display_white = 1;
  return f;
}

}  // namespace

TEST_CASE("Iodine and water follow the NIST table, with the K edge", "[render][formation]") {
  // Tabulated energies return the table (NIST SRD 126, Tables 3 and 4).
  CHECK(iodine_mass_attenuation(30) == Approx(8.561).epsilon(1e-12));
  CHECK(iodine_mass_attenuation(50) == Approx(12.32).epsilon(1e-12));
  CHECK(iodine_mass_attenuation(60) == Approx(7.579).epsilon(1e-12));
  CHECK(iodine_mass_attenuation(100) == Approx(1.942).epsilon(1e-12));
  CHECK(water_mass_attenuation(40) == Approx(0.2683).epsilon(1e-12));
  CHECK(water_mass_attenuation(80) == Approx(0.1837).epsilon(1e-12));
  // The K edge: on it and above, the value above; just below, close to the value below.
  CHECK(iodine_mass_attenuation(kIodineKEdgeKev) == Approx(35.82).epsilon(1e-12));
  CHECK(iodine_mass_attenuation(kIodineKEdgeKev - 1e-6) == Approx(6.553).epsilon(1e-5));
  CHECK(iodine_mass_attenuation(kIodineKEdgeKev + 0.01) /
            iodine_mass_attenuation(kIodineKEdgeKev - 0.01) >
        5.0);
  // Between: log-log, by hand: 12.32 (55/50)^(ln(7.579/12.32)/ln(60/50)) = 9.5583.
  CHECK(iodine_mass_attenuation(55) == Approx(9.5583).epsilon(2e-4));
  CHECK(water_mass_attenuation(55) == Approx(0.21567).epsilon(2e-4));
  // Mixture: 175 mgI/mL at 55 keV = 0.175 x 9.5583 + 1.06 x 0.21567 = 1.9013 cm^-1.
  CHECK(iodinated_blood_mu_per_mm(175, 55) == Approx(0.19013).epsilon(5e-4));
  CHECK(blood_mu_per_mm(55) == Approx(0.022861).epsilon(5e-4));
  // A 3 mm lumen at the defaults adds 0.4-0.55 to the line integral at its centre.
  const IodineContrast contrast;
  const double added = 3.0 * (contrast.lumen_mu_per_mm() - contrast.blood_mu_per_mm());
  INFO("3 mm lumen: " << added);
  CHECK((added > 0.4 && added < 0.55));
  // More iodine, more attenuation; higher energy (above the edge), less.
  CHECK(iodinated_blood_mu_per_mm(300, 55) > iodinated_blood_mu_per_mm(150, 55));
  CHECK(iodinated_blood_mu_per_mm(175, 70) < iodinated_blood_mu_per_mm(175, 50));
  CHECK(hu_equivalent(water_mu_per_mm(60), 60) == Approx(0.0).margin(1e-9));
  CHECK(contrast.lumen_hu() == Approx(1000 * (0.19013 / 0.021567 - 1)).epsilon(1e-3));
  CHECK_THROWS_WITH(iodine_mass_attenuation(25),
                    Catch::Contains("energy") && Catch::Contains("25"));
  CHECK_THROWS_WITH(iodinated_blood_mu_per_mm(-5, 55),
                    Catch::Contains("iodine concentration") && Catch::Contains("-5"));
  CHECK_THROWS_WITH(iodinated_blood_mu_per_mm(std::nan(""), 55), Catch::Contains("nan"));
}

TEST_CASE("The broad blur matches a direct Gaussian", "[render][formation]") {
  Image<float> image(200, 200, 0.0f);
  for (int r = 0; r < 200; ++r)
    for (int c = 100; c < 200; ++c) image(r, c) = 1.0f;
  image(60, 50) = 100.0f;
  for (double sigma : {20.0, 40.0}) {
    const Image<float> exact = gaussian_blur(image, sigma);
    const Image<float> broad = detail::broad_gaussian_blur(image, sigma);
    double worst = 0;
    for (std::size_t p = 0; p < exact.size(); ++p)
      worst = std::max(worst, double(std::abs(exact.data()[p] - broad.data()[p])));
    INFO("sigma " << sigma << ": largest difference " << worst);
    CHECK(worst < 0.01);
  }
}

TEST_CASE("Each acquisition step does what its physics says", "[render][formation]") {
  Rng rng(1);
  const Image<float> scene = slab_with_vessel();
  const double background = scene(128, 20), centre = scene(128, kVesselCol);
  const double od = centre - background;  // the lumen's optical depth over the slab

  SECTION("log and window: display = 1 - (line integral - background) / width") {
    AngiogramFormation f = bare();
    const FormedAngiogram out = form_angiogram(scene, kPixelMm, f, rng);
    CHECK(out.window_hi == Approx(-background).epsilon(1e-5));
    CHECK(out.display(128, 20) == Approx(1.0).margin(1e-5));
    CHECK(out.display(128, kVesselCol) == Approx(1.0 - od / f.window_width).margin(1e-4));
    CHECK(out.quantised.empty());
  }
  SECTION("scatter: log contrast ln((P_v + SPR P_b) / (P_b (1 + SPR)))") {
    AngiogramFormation f = bare();
    f.scatter_to_primary = 0.8;
    const FormedAngiogram out = form_angiogram(scene, kPixelMm, f, rng);
    const double expected = -std::log((std::exp(-od) + 0.8) / 1.8);
    const double seen = out.display(128, 20) - out.display(128, kVesselCol);
    INFO("scatter contrast " << seen << ", predicted " << expected << ", primary only " << od);
    CHECK(seen == Approx(expected).epsilon(0.03));
    CHECK(seen < 0.8 * od);
  }
  SECTION("quantum noise: sigma of ln(n / N0) = 1 / sqrt(photons); AEC holds the dose") {
    AngiogramFormation f = bare();
    f.detector_photons = 2500;
    f.window_high_percentile = 99.5;
    const FormedAngiogram out = form_angiogram(scene, kPixelMm, f, rng);
    CHECK(out.photons_per_unit * std::exp(-background) == Approx(2500).epsilon(0.02));
    const Measured m = measure(out.display);
    INFO("noise " << m.noise);
    CHECK(m.noise == Approx(1.0 / std::sqrt(2500.0) / f.window_width).epsilon(0.08));
    f.electronic_noise = 50;  // in quadrature: sqrt(2500 + 50^2) / 2500
    const Measured with_electronic = measure(form_angiogram(scene, kPixelMm, f, rng).display);
    CHECK(with_electronic.noise == Approx(std::sqrt(5000.0) / 2500 / f.window_width).epsilon(0.08));
  }
  SECTION("edge enhancement deepens the vessel; blur makes it shallower") {
    AngiogramFormation f = bare();
    const double plain = measure(form_angiogram(scene, kPixelMm, f, rng).display).contrast;
    f.edge_gain = 1.0;
    const double sharpened = measure(form_angiogram(scene, kPixelMm, f, rng).display).contrast;
    f.edge_gain = 0;
    f.detector_blur_px = 3;
    const double blurred = measure(form_angiogram(scene, kPixelMm, f, rng).display).contrast;
    INFO("plain " << plain << ", sharpened " << sharpened << ", blurred " << blurred);
    CHECK(sharpened > 1.15 * plain);
    CHECK(blurred < 0.9 * plain);
  }
  SECTION("gamma and quantisation") {
    AngiogramFormation f = bare();
    f.gamma = 2.0;
    f.bits = 8;
    const FormedAngiogram out = form_angiogram(scene, kPixelMm, f, rng);
    const double v = 1.0 - od / f.window_width;
    CHECK(out.quantised(128, kVesselCol) == std::lround(v * v * 255));
    CHECK(out.display(128, kVesselCol) == Approx(std::lround(v * v * 255) / 255.0).margin(1e-6));
    CHECK(out.quantised(128, 20) == 255);
    f.bits = 16;
    CHECK(form_angiogram(scene, kPixelMm, f, rng).quantised(128, 20) == 65535);
  }
}

TEST_CASE("The exposure control senses the dose at the image centre, over the heart",
          "[render][formation]") {
  // A dark centre (the heart: optical depth 5) in bright surroundings (the lungs: 3) that
  // cover most of the field: a field-wide median would set the dose on the lungs and starve
  // the heart of quanta.
  Image<float> scene(256, 256, 3.0f);
  for (int r = 80; r < 176; ++r)
    for (int c = 80; c < 176; ++c) scene(r, c) = 5.0f;
  AngiogramFormation f = bare();
  f.detector_photons = 4000;
  Rng rng(3);
  const FormedAngiogram out = form_angiogram(scene, kPixelMm, f, rng);
  // The sensed region (rows and columns 64-191) is 56% heart: its median is the heart's.
  CHECK(out.photons_per_unit * std::exp(-5.0) == Approx(4000).epsilon(1e-4));
  // A field with nothing exposed at the centre falls back to the whole field.
  Image<std::uint8_t> corner(256, 256, 0);
  for (int r = 0; r < 40; ++r)
    for (int c = 0; c < 40; ++c) corner(r, c) = 1;
  const Image<std::uint8_t> sensed = detail::exposure_sensing_mask(corner);
  CHECK(sensed.storage() == corner.storage());
  Image<std::uint8_t> full(256, 256, 1);
  const Image<std::uint8_t> centre = detail::exposure_sensing_mask(full);
  CHECK(centre(64, 64) == 1);
  CHECK(centre(191, 191) == 1);
  CHECK(centre(63, 128) == 0);
  CHECK(centre(128, 192) == 0);
}

TEST_CASE("A 3 mm vessel in a water slab looks as in clinical frames at the defaults",
          "[render][formation]") {
  const AngiogramFormation defaults;
  const Image<float> scene = slab_with_vessel();
  AngiogramFormation quiet = defaults;
  quiet.detector_photons = 0;
  Rng rng(7);
  // Measured in the display's own range, as a per-frame normalisation of a real frame sees it
  // (real frames span about 0.2-0.8 raw; the display levels put the DRR there).
  const double range = defaults.display_white - defaults.display_black;
  const auto in_range = [&](Measured m) {
    m.contrast /= range;
    m.noise /= range;
    return m;
  };
  const FormedAngiogram quiet_out = form_angiogram(scene, kPixelMm, quiet, rng);
  const Measured clean = in_range(measure(quiet_out.display));
  const Measured noisy = in_range(measure(form_angiogram(scene, kPixelMm, defaults, rng).display));
  // The display levels: inside the field nothing brighter than white or darker than black
  // (to the 8-bit step).
  double lo = 1, hi = 0;
  for (std::size_t p = 0; p < quiet_out.display.size(); ++p)
    if (quiet_out.field_mask.data()[p]) {
      lo = std::min(lo, double(quiet_out.display.data()[p]));
      hi = std::max(hi, double(quiet_out.display.data()[p]));
    }
  CHECK(lo >= defaults.display_black - 0.5 / 255);
  CHECK(hi <= defaults.display_white + 0.5 / 255);
  CHECK(hi - lo > 0.5 * (defaults.display_white - defaults.display_black));
  WARN("defaults: contrast without noise " << clean.contrast << "; with noise contrast "
                                           << noisy.contrast << ", noise sigma " << noisy.noise
                                           << ", CNR " << noisy.cnr);
  // Clinical frames: contrast 0.25-0.8 (typ. 0.53), noise 0.012-0.05, CNR 10-26 (5-40 kept).
  CHECK((clean.contrast > 0.25 && clean.contrast < 0.8));
  CHECK((noisy.contrast > 0.25 && noisy.contrast < 0.8));
  CHECK((noisy.noise > 0.01 && noisy.noise < 0.06));
  CHECK((noisy.cnr > 5 && noisy.cnr < 40));
  // The bare DRR display (log, window) the formation replaces has no noise at all.
  CHECK(measure(form_angiogram(scene, kPixelMm, bare(), rng).display).noise < 1e-3);
}

TEST_CASE("Formation is deterministic in its seed", "[render][formation]") {
  const AngiogramFormation f;
  const Image<float> scene = slab_with_vessel();
  Rng a(11), b(11), c(12);
  const FormedAngiogram x = form_angiogram(scene, kPixelMm, f, a);
  const FormedAngiogram y = form_angiogram(scene, kPixelMm, f, b);
  const FormedAngiogram z = form_angiogram(scene, kPixelMm, f, c);
  CHECK(x.display.storage() == y.display.storage());
  CHECK(x.quantised.storage() == y.quantised.storage());
  CHECK(x.display.storage() != z.display.storage());
  // Randomised formations too.
  Rng r1(5), r2(5), r3(6);
  const AngiogramFormationRanges ranges;
  CHECK(to_json(randomize(ranges, r1)) == to_json(randomize(ranges, r2)));
  Rng r4(5);
  CHECK(to_json(randomize(ranges, r4)) != to_json(randomize(ranges, r3)));
}

TEST_CASE("Shutters: the field is 1 inside, 0 outside, the penumbra monotonic",
          "[render][formation]") {
  for (ShutterShape shape :
       {ShutterShape::rectangular, ShutterShape::octagonal, ShutterShape::circular}) {
    Shutter s;
    s.shape = shape;
    s.half_width = 0.8;
    s.half_height = 0.6;
    s.corner_cut = 0.5;
    s.radius = 0.7;
    s.penumbra_px = 8;
    const int rows = 200, cols = 240;
    INFO("shape " << to_string(shape));
    const Image<std::uint8_t> mask = shutter_field_mask(s, rows, cols);
    const Image<float> exposure = shutter_exposure(s, rows, cols);
    CHECK(int(mask(100, 120)) == 1);  // the centre
    CHECK(int(mask(0, 0)) == 0);      // a corner
    CHECK(int(mask(100, 1)) == 0);    // beyond the left blade (half width 0.8: edge at 24 px)
    CHECK(exposure(100, 120) == Approx(1.0).margin(1e-6));
    CHECK(exposure(0, 0) == Approx(0.0).margin(1e-6));
    // Mask = the half-exposure contour.
    for (std::size_t p = 0; p < mask.size(); ++p)
      REQUIRE((mask.data()[p] == 1) == (exposure.data()[p] >= 0.5f));
    // Along rays from the centre: exposure never rises going out, and crosses the whole range.
    for (double angle : {0.0, 0.7, 1.5708, 2.4, 3.1416, 4.0}) {
      double previous = 2;
      for (double t = 0; t < 160; t += 0.5) {
        const double row = 99.5 + t * std::sin(angle), col = 119.5 + t * std::cos(angle);
        const double e = s.exposure(rows, cols, row, col);
        REQUIRE(e <= previous + 1e-12);
        previous = e;
      }
      CHECK(previous < 1e-6);
    }
    // The octagon cuts the rectangle's corners; the circle is round.
    if (shape == ShutterShape::octagonal) {
      Shutter rect = s;
      rect.shape = ShutterShape::rectangular;
      const double corner_row = 100 - 0.6 * 100 + 3, corner_col = 120 - 0.8 * 120 + 3;
      CHECK(rect.signed_distance(rows, cols, corner_row, corner_col) > 0);
      CHECK(s.signed_distance(rows, cols, corner_row, corner_col) < 0);
    }
    if (shape == ShutterShape::circular)
      CHECK(s.signed_distance(rows, cols, 99.5 + 70, 119.5) ==
            Approx(s.signed_distance(rows, cols, 99.5, 119.5 - 70)).margin(1e-9));
    // On the image: the frame takes frame_level; the field keeps its values.
    Image<float> display(rows, cols, 0.8f);
    apply_shutter(display, s);
    CHECK(display(0, 0) == Approx(s.frame_level).margin(1e-6));
    CHECK(display(100, 120) == Approx(0.8).margin(1e-6));
  }
  // No penumbra: a hard edge.
  Shutter hard;
  hard.penumbra_px = 0;
  const Image<float> e = shutter_exposure(hard, 100, 100);
  for (float v : e.storage()) REQUIRE((v == 0.0f || v == 1.0f));
  // No shutter: everything exposed.
  Shutter none;
  none.shape = ShutterShape::none;
  const Image<std::uint8_t> all = shutter_field_mask(none, 10, 10);
  for (auto v : all.storage()) REQUIRE(int(v) == 1);
}

TEST_CASE("validate() names the bad parameter and value", "[render][formation]") {
  const auto rejects = [](AngiogramFormation f, const char* name, const char* value) {
    INFO(name);
    CHECK_THROWS_WITH(f.validate(), Catch::Contains(name) && Catch::Contains(value));
  };
  AngiogramFormation f;
  CHECK_NOTHROW(f.validate());
  f = {};
  f.scatter_to_primary = std::nan("");
  rejects(f, "scatter_to_primary", "nan");
  f = {};
  f.scatter_to_primary = -0.1;
  rejects(f, "scatter_to_primary", "-0.1");
  f = {};
  f.detector_photons = -100;
  rejects(f, "detector_photons", "-100");
  f = {};
  f.detector_photons = 5;
  rejects(f, "detector_photons", "5");
  f = {};
  f.gamma = 0;
  rejects(f, "gamma", "0");
  f = {};
  f.edge_radius_px = std::numeric_limits<double>::infinity();
  rejects(f, "edge_radius_px", "inf");
  f = {};
  f.window_high_percentile = 50;
  rejects(f, "window_high_percentile", "50");
  f = {};
  f.bits = 12;
  rejects(f, "bits", "12");
  f = {};
  f.shutter.penumbra_px = -2;
  rejects(f, "penumbra_px", "-2");
  f = {};
  f.shutter.radius = 3;
  rejects(f, "radius", "3");
  IodineContrast contrast;
  contrast.effective_kev = 120;
  CHECK_THROWS_WITH(contrast.validate(),
                    Catch::Contains("effective_kev") && Catch::Contains("120"));
  contrast = {};
  contrast.iodine_mg_per_ml = 500;
  CHECK_THROWS_WITH(contrast.validate(),
                    Catch::Contains("iodine_mg_per_ml") && Catch::Contains("500"));
  IodineContrastRanges contrast_ranges;
  contrast_ranges.effective_kev = {20, 60};
  CHECK_THROWS_WITH(contrast_ranges.validate(),
                    Catch::Contains("effective_kev") && Catch::Contains("20"));
  // The chain checks its inputs.
  Rng rng(0);
  Image<float> bad(4, 4, 1.0f);
  bad(2, 2) = -1.0f;
  CHECK_THROWS_WITH(form_angiogram(bad, kPixelMm, AngiogramFormation{}, rng),
                    Catch::Contains("line integrals") && Catch::Contains("-1"));
  CHECK_THROWS_WITH(form_angiogram(Image<float>(4, 4, 1.0f), 0.0, AngiogramFormation{}, rng),
                    Catch::Contains("pixel_mm"));
  // Ranges: an end outside the parameter's range, or lo > hi, is named.
  AngiogramFormationRanges ranges;
  ranges.scatter_to_primary = {0.5, 0.2};
  CHECK_THROWS_WITH(ranges.validate(), Catch::Contains("scatter_to_primary"));
  ranges = {};
  ranges.gamma = {0.1, 1.0};
  CHECK_THROWS_WITH(ranges.validate(), Catch::Contains("gamma") && Catch::Contains("0.1"));
  ranges = {};
  ranges.weight_none = ranges.weight_rectangular = ranges.weight_octagonal =
      ranges.weight_circular = 0;
  CHECK_THROWS_WITH(ranges.validate(), Catch::Contains("weights"));
}

TEST_CASE("The JSON record round-trips and refuses bad fields", "[render][formation]") {
  Rng rng(3);
  for (int k = 0; k < 8; ++k) {
    const AngiogramFormation f = randomize(AngiogramFormationRanges{}, rng);
    const nlohmann::json j = to_json(f);
    const AngiogramFormation back =
        angiogram_formation_from_json(nlohmann::json::parse(j.dump()), "view");
    CHECK(to_json(back) == j);
    CHECK(back.detector_photons == f.detector_photons);
    CHECK(back.shutter.shape == f.shutter.shape);
    CHECK(back.shutter.center_v == f.shutter.center_v);
  }
  for (int k = 0; k < 4; ++k) {
    const IodineContrast c = randomize(IodineContrastRanges{}, rng);
    const IodineContrast back = iodine_contrast_from_json(to_json(c), "view");
    CHECK(back.iodine_mg_per_ml == c.iodine_mg_per_ml);
    CHECK(back.effective_kev == c.effective_kev);
  }
  CHECK_THROWS_WITH(iodine_contrast_from_json({{"iodine_mg_per_ml", 175}}, "view 2"),
                    Catch::Contains("effective_kev") && Catch::Contains("view 2"));
  nlohmann::json j = to_json(AngiogramFormation{});
  j["gamma"] = -1;
  CHECK_THROWS_AS(angiogram_formation_from_json(j, "view 3"), FormatError);
  CHECK_THROWS_WITH(angiogram_formation_from_json(j, "view 3"),
                    Catch::Contains("view 3") && Catch::Contains("gamma"));
  j = to_json(AngiogramFormation{});
  j["shutter"]["shape"] = "hexagonal";
  CHECK_THROWS_WITH(angiogram_formation_from_json(j, "view 3"),
                    Catch::Contains("hexagonal") && Catch::Contains("view 3"));
  j = to_json(AngiogramFormation{});
  j["gama"] = 1.0;
  CHECK_THROWS_WITH(angiogram_formation_from_json(j, "view 3"), Catch::Contains("'gama'"));
  j = to_json(AngiogramFormation{});
  j.erase("edge_gain");
  CHECK_THROWS_WITH(angiogram_formation_from_json(j, "view 3"), Catch::Contains("edge_gain"));
  j = to_json(AngiogramFormation{});
  j["bits"] = 8.5;
  CHECK_THROWS_WITH(angiogram_formation_from_json(j, "view 3"), Catch::Contains("bits"));
}

TEST_CASE("Randomised formations stay inside their ranges and mostly the clinical look",
          "[render][formation]") {
  const AngiogramFormationRanges ranges;
  Rng rng(2024);
  int shapes[4] = {0, 0, 0, 0}, clinical = 0;
  const int draws = 40;
  double lowest_contrast = 1, highest_contrast = 0, lowest_cnr = 1e9, highest_cnr = 0;
  for (int k = 0; k < draws; ++k) {
    const IodineContrast contrast = randomize(IodineContrastRanges{}, rng);
    CHECK((contrast.iodine_mg_per_ml >= 140 && contrast.iodine_mg_per_ml <= 240));
    AngiogramFormation f = randomize(ranges, rng);
    CHECK_NOTHROW(f.validate());
    CHECK((f.scatter_to_primary >= 0.3 && f.scatter_to_primary <= 0.9));
    CHECK((f.detector_photons >= 2500 && f.detector_photons <= 12000));
    ++shapes[static_cast<int>(f.shutter.shape)];
    // The measurement needs the vessel and the noise patch inside the field.
    f.shutter.shape = ShutterShape::none;
    Rng noise = rng.fork(static_cast<std::uint64_t>(k));
    Measured m = measure(form_angiogram(slab_with_vessel(contrast), kPixelMm, f, noise).display);
    m.contrast /= f.display_white - f.display_black;  // in the display's range, as above
    m.noise /= f.display_white - f.display_black;
    lowest_contrast = std::min(lowest_contrast, m.contrast);
    highest_contrast = std::max(highest_contrast, m.contrast);
    lowest_cnr = std::min(lowest_cnr, m.cnr);
    highest_cnr = std::max(highest_cnr, m.cnr);
    clinical += m.contrast >= 0.25 && m.contrast <= 0.8 && m.cnr >= 5 && m.cnr <= 40;
  }
  WARN(draws << " randomised formations: contrast " << lowest_contrast << " - " << highest_contrast
             << ", CNR " << lowest_cnr << " - " << highest_cnr << "; " << clinical
             << " inside contrast 0.25-0.8 and CNR 5-40");
  CHECK(clinical >= 0.8 * draws);
  CHECK(lowest_contrast > 0.15);
  CHECK(highest_contrast < 0.9);
  CHECK(lowest_cnr > 4);
  CHECK(highest_cnr < 45);
  for (int s = 0; s < 4; ++s) CHECK(shapes[s] > 0);
}
