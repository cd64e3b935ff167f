#pragma once
/// Image formation as a C-arm makes an angiogram: from a view's line integrals (or transmitted
/// intensity) to the displayed frame, through the acquisition (scatter, blur, quantum and
/// electronic noise, shutters) and the system's image processing (log, range compression, edge
/// enhancement, window, gamma, quantisation). One seeded, recorded, randomisable model;
/// docs/realism.md ("Image formation") has the equations, ranges and sources.
///
/// Why: a bare DRR (exp(-line integral), windowed) has vessel contrast 0.03-0.08 and noise
/// sigma ~1e-4 in display units, where clinical frames measure 0.25-0.8 and 0.012-0.05 (CNR
/// 10-26): a matcher trained on the first learns nothing about the second.
///
/// The chain, per pixel (P the primary transmitted fraction exp(-line integral), I0 = 1):
///   scatter     S = SPR G_scatter * P                (convolution model, SPR the flat-field
///                                                     scatter-to-primary ratio)
///   blur        D = G_blur * (P + S)                 (focal spot and detector in quadrature)
///   dose (AEC)  N0 = photons / median_sensed(D)      (the exposure control holds the detector
///                                                     dose, whatever the patient's thickness,
///                                                     where it senses it: the central half of
///                                                     the image in each direction, inside the
///                                                     shutters - over the heart, not the lungs)
///   noise       n = Poisson(N0 D) + Normal(0, e)     (e: electronic noise, photon units)
///   log         s = ln(max(n, 0.5) / N0)             (s = ln D without noise)
///   compress    s = s - k G_range * s                (dynamic-range compression)
///   edges       s = s + g (s - G_edge * s)           (unsharp-mask edge enhancement)
///   window      v = (s - lo) / (hi - lo), clamped    (lo, hi: percentiles of s in the exposed
///                                                     field, hi - lo at least min_width; or a
///                                                     fixed width below the hi percentile)
///   gamma       v = v^gamma
///   display     v = black + (white - black) v       (the monitor's levels: real cine frames
///                                                     span about 0.2-0.8, not 0-1)
///   shutter     v = e v + (1 - e) frame_level        (render/collimator.hpp)
///   quantise    v = round(v (2^bits - 1)) / (2^bits - 1)
/// Display convention as gimm's images: [0, 1], bright background, dark vessels.
///
/// The iodine of the injection is not a step here: it acts where the attenuation is built
/// (render/iodine.hpp, IodineContrast), before the line integrals. This chain is what follows.
///
/// Deterministic: all noise comes from the caller's gimm::Rng, drawn in row-major pixel order.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/core/filter.hpp"
#include "gimm/core/image.hpp"
#include "gimm/core/rng.hpp"
#include "gimm/render/collimator.hpp"
#include "gimm/render/image_degradation.hpp"
#include "gimm/render/iodine.hpp"

namespace gimm {

/// How the log image is windowed to [0, 1]. percentile: between two percentiles of the exposed
/// field (as a system's automatic window), at least window_min_width wide; fixed: the window
/// is window_width wide and ends at the high percentile (a set contrast gain).
enum class WindowMode { percentile, fixed };

inline WindowMode parse_window_mode(const std::string& s) {
  if (s == "percentile") return WindowMode::percentile;
  if (s == "fixed") return WindowMode::fixed;
  GIMM_FAIL("window mode must be percentile|fixed, got '" << s << "'");
}
inline const char* to_string(WindowMode m) {
  return m == WindowMode::fixed ? "fixed" : "percentile";
}

/// Every parameter with its unit, the range validate() accepts, and the clinical default
/// (docs/realism.md gives the source of each).
struct AngiogramFormation {
  // Acquisition.
  /// Scatter-to-primary ratio behind the anti-scatter grid, [0, 3]; cardiac 0.3-1.
  double scatter_to_primary = 0.5;
  /// Width (sigma) of the scatter kernel at the detector, mm, [1, 200].
  double scatter_sigma_mm = 40;
  /// Focal-spot blur at the detector, sigma in px, [0, 8].
  double focal_spot_blur_px = 0.5;
  /// Detector (scintillator) blur, sigma in px, [0, 8].
  double detector_blur_px = 0.7;
  /// Quanta per pixel at the field's median detector signal (the dose level the exposure
  /// control holds), [10, 1e7]; 0 = no noise at all (quantum or electronic).
  double detector_photons = 4000;
  /// Electronic (read-out) noise, sigma in photon-equivalents per pixel, [0, 1000].
  double electronic_noise = 10;
  // Processing.
  /// Dynamic-range compression: fraction of the low-pass log image removed, [0, 0.95].
  double range_compression = 0.5;
  /// Low-pass of the range compression, sigma in px, [1, 512].
  double range_compression_sigma_px = 48;
  /// Unsharp-mask gain, [0, 5]; 0 = no edge enhancement.
  double edge_gain = 0.6;
  /// Unsharp-mask radius (Gaussian sigma), px, [0.5, 32].
  double edge_radius_px = 3;
  WindowMode window = WindowMode::percentile;
  double window_low_percentile = 0.5;    ///< %, [0, 20]
  double window_high_percentile = 99.5;  ///< %, [80, 100]
  /// Percentile window: the least width in log units, [0.05, 10] (the system's largest
  /// contrast gain: a flat field's noise is not stretched to full scale).
  double window_min_width = 0.8;
  double window_width = 1.0;  ///< fixed window: width in log units, [0.05, 10]
  double gamma = 1.0;         ///< display gamma, v^gamma, [0.3, 3]
  /// Display levels the window maps to: black (the darkest vessel) and white (the brightest
  /// lung), [0, 0.5] and [0.5, 1]. Four clinical frames span 0.28 (1st percentile) to 0.71
  /// (99th) (docs/realism.md); 0 and 1 stretch a DRR over the whole range.
  double display_black = 0.2, display_white = 0.78;
  int bits = 8;     ///< 8 or 16: quantise; 0: keep floats
  Shutter shutter;  ///< render/collimator.hpp

  void validate() const {
    const auto in = [](const char* name, double v, double lo, double hi, const char* unit) {
      GIMM_CHECK(std::isfinite(v) && v >= lo && v <= hi,
                 "angiogram formation: " << name << " must be in [" << lo << ", " << hi << "]"
                                         << unit << ", got " << v);
    };
    in("scatter_to_primary", scatter_to_primary, 0, 3, "");
    in("scatter_sigma_mm", scatter_sigma_mm, 1, 200, " mm");
    in("focal_spot_blur_px", focal_spot_blur_px, 0, 8, " px");
    in("detector_blur_px", detector_blur_px, 0, 8, " px");
    GIMM_CHECK(detector_photons == 0 || (std::isfinite(detector_photons) &&
                                         detector_photons >= 10 && detector_photons <= 1e7),
               "angiogram formation: detector_photons must be 0 (no noise) or in [10, 1e7], got "
                   << detector_photons);
    in("electronic_noise", electronic_noise, 0, 1000, " photons");
    in("range_compression", range_compression, 0, 0.95, "");
    in("range_compression_sigma_px", range_compression_sigma_px, 1, 512, " px");
    in("edge_gain", edge_gain, 0, 5, "");
    in("edge_radius_px", edge_radius_px, 0.5, 32, " px");
    in("window_low_percentile", window_low_percentile, 0, 20, " %");
    in("window_high_percentile", window_high_percentile, 80, 100, " %");
    in("window_min_width", window_min_width, 0.05, 10, " log units");
    in("window_width", window_width, 0.05, 10, " log units");
    in("gamma", gamma, 0.3, 3, "");
    in("display_black", display_black, 0, 0.5, "");
    in("display_white", display_white, 0.5, 1, "");
    GIMM_CHECK(display_black < display_white,
               "angiogram formation: display_black ("
                   << display_black << ") must be below display_white (" << display_white << ")");
    GIMM_CHECK(bits == 0 || bits == 8 || bits == 16,
               "angiogram formation: bits must be 0 (float), 8 or 16, got " << bits);
    shutter.validate();
  }
};

struct FormedAngiogram {
  Image<float> display;                 ///< [0, 1], bright background, dark vessels
  Image<std::uint16_t> quantised;       ///< levels 0 .. 2^bits - 1; empty when bits is 0
  Image<std::uint8_t> field_mask;       ///< 1 = exposed field (shutter_field_mask)
  double photons_per_unit = 0;          ///< N0: quanta for a detector signal of 1 (0: no noise)
  double window_lo = 0, window_hi = 0;  ///< the window, log units
};

namespace detail {

/// Where the exposure control senses the dose: the exposed pixels of the image's central half
/// in each direction (a cardiac system's measuring field sits at the centre, on the heart); the
/// whole exposed field when the shutters leave nothing there.
inline Image<std::uint8_t> exposure_sensing_mask(const Image<std::uint8_t>& field) {
  const int rows = field.rows(), cols = field.cols();
  Image<std::uint8_t> sensed(rows, cols, 0);
  bool any = false;
  for (int r = rows / 4; r < rows - rows / 4; ++r)
    for (int c = cols / 4; c < cols - cols / 4; ++c)
      if (field(r, c)) sensed(r, c) = 1, any = true;
  return any ? sensed : field;
}

/// A Gaussian blur for the broad kernels of scatter and range compression (tens of px, beyond
/// a direct kernel's cost and gaussian_blur's 64 px): box-average f x f blocks, blur the small
/// image, interpolate bilinearly back. The box adds (f^2 - 1) / 12 px^2 of variance and the
/// interpolation about f^2 / 6: the small blur takes them off. These kernels model smooth
/// physics (scatter) or a smooth processing step, so the approximation is far below the
/// models' own uncertainty.
inline Image<float> broad_gaussian_blur(const Image<float>& image, double sigma) {
  if (sigma <= 12 || image.empty()) return gaussian_blur(image, sigma);
  const int f = static_cast<int>(std::ceil(sigma / 6));
  const int rows = image.rows(), cols = image.cols();
  const int sr = (rows + f - 1) / f, sc = (cols + f - 1) / f;
  Image<float> small(sr, sc, 0.0f), count(sr, sc, 0.0f);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      small(r / f, c / f) += image(r, c);
      count(r / f, c / f) += 1;
    }
  for (std::size_t p = 0; p < small.size(); ++p) small.data()[p] /= count.data()[p];
  const double extra = (f * f - 1) / 12.0 + f * f / 6.0;
  small = gaussian_blur(small, std::sqrt(std::max(sigma * sigma - extra, 0.0)) / f);
  Image<float> out(rows, cols);
  const auto coordinate = [f](int x, int n, int& i0, int& i1, double& t) {
    const double s = std::clamp((x - (f - 1) / 2.0) / f, 0.0, double(n - 1));
    i0 = static_cast<int>(s);
    i1 = std::min(i0 + 1, n - 1);
    t = s - i0;
  };
  for (int r = 0; r < rows; ++r) {
    int r0, r1;
    double tr;
    coordinate(r, sr, r0, r1, tr);
    for (int c = 0; c < cols; ++c) {
      int c0, c1;
      double tc;
      coordinate(c, sc, c0, c1, tc);
      const double top = (1 - tc) * small(r0, c0) + tc * small(r0, c1);
      const double bottom = (1 - tc) * small(r1, c0) + tc * small(r1, c1);
      out(r, c) = static_cast<float>((1 - tr) * top + tr * bottom);
    }
  }
  return out;
}

/// Nearest-rank percentile (pct in [0, 100]) of the pixels of `image` where `mask` is nonzero
/// (all pixels when no pixel is); deterministic (nth_element on a copy).
inline double masked_percentile(const Image<float>& image, const Image<std::uint8_t>& mask,
                                double pct) {
  std::vector<float> values;
  values.reserve(image.size());
  for (std::size_t p = 0; p < image.size(); ++p)
    if (mask.data()[p]) values.push_back(image.data()[p]);
  if (values.empty()) values = image.storage();
  const auto k = static_cast<std::size_t>(std::llround(pct / 100.0 * double(values.size() - 1)));
  std::nth_element(values.begin(), values.begin() + std::ptrdiff_t(k), values.end());
  return values[k];
}

}  // namespace detail

/// The displayed angiogram of a view whose primary transmitted fraction (I / I0, in [0, 1]) is
/// `primary`. `pixel_mm`: the detector pixel size (mm), for the scatter kernel. The noise is
/// drawn from `rng` (untouched without noise).
inline FormedAngiogram form_angiogram_from_intensity(const Image<float>& primary, double pixel_mm,
                                                     const AngiogramFormation& f, Rng& rng) {
  f.validate();
  GIMM_CHECK(!primary.empty(), "angiogram formation: the image is empty");
  GIMM_CHECK(std::isfinite(pixel_mm) && pixel_mm > 0 && pixel_mm <= 10,
             "angiogram formation: pixel_mm must be in (0, 10] mm, got " << pixel_mm);
  for (std::size_t p = 0; p < primary.size(); ++p)
    GIMM_CHECK(std::isfinite(primary.data()[p]) && primary.data()[p] >= 0,
               "angiogram formation: transmitted intensity must be finite and >= 0, got "
                   << primary.data()[p] << " at pixel " << p);
  const int rows = primary.rows(), cols = primary.cols();
  FormedAngiogram out;
  out.field_mask = shutter_field_mask(f.shutter, rows, cols);

  // Acquisition: scatter, blur, dose, noise.
  Image<float> detected = primary;
  if (f.scatter_to_primary > 0) {
    const Image<float> scatter =
        detail::broad_gaussian_blur(primary, f.scatter_sigma_mm / pixel_mm);
    for (std::size_t p = 0; p < detected.size(); ++p)
      detected.data()[p] += static_cast<float>(f.scatter_to_primary * scatter.data()[p]);
  }
  detected = gaussian_blur(detected, std::hypot(f.focal_spot_blur_px, f.detector_blur_px));
  Image<float> s(rows, cols);
  if (f.detector_photons > 0) {
    const double median =
        detail::masked_percentile(detected, detail::exposure_sensing_mask(out.field_mask), 50);
    GIMM_CHECK(median > 0,
               "angiogram formation: no signal reaches the detector's field (median "
               "transmitted intensity "
                   << median << ")");
    const double n0 = f.detector_photons / median;
    out.photons_per_unit = n0;
    for (std::size_t p = 0; p < s.size(); ++p) {
      double n = poisson_draw(n0 * detected.data()[p], rng);
      if (f.electronic_noise > 0) n += f.electronic_noise * rng.normal();
      s.data()[p] = static_cast<float>(std::log(std::max(n, 0.5) / n0));
    }
  } else {
    for (std::size_t p = 0; p < s.size(); ++p)
      s.data()[p] = static_cast<float>(std::log(std::max(double(detected.data()[p]), 1e-30)));
  }

  // Processing: range compression, edge enhancement, window, gamma.
  if (f.range_compression > 0) {
    const Image<float> low = detail::broad_gaussian_blur(s, f.range_compression_sigma_px);
    for (std::size_t p = 0; p < s.size(); ++p)
      s.data()[p] -= static_cast<float>(f.range_compression * low.data()[p]);
  }
  if (f.edge_gain > 0) {
    const Image<float> low = gaussian_blur(s, f.edge_radius_px);
    for (std::size_t p = 0; p < s.size(); ++p)
      s.data()[p] += static_cast<float>(f.edge_gain * (s.data()[p] - low.data()[p]));
  }
  const double hi = detail::masked_percentile(s, out.field_mask, f.window_high_percentile);
  double lo = hi - f.window_width;
  if (f.window == WindowMode::percentile)
    lo = std::min(detail::masked_percentile(s, out.field_mask, f.window_low_percentile),
                  hi - f.window_min_width);
  out.window_lo = lo;
  out.window_hi = hi;
  out.display = Image<float>(rows, cols);
  for (std::size_t p = 0; p < s.size(); ++p) {
    const double v = std::clamp((s.data()[p] - lo) / (hi - lo), 0.0, 1.0);
    const double shown = f.gamma == 1 ? v : std::pow(v, f.gamma);
    out.display.data()[p] =
        static_cast<float>(f.display_black + (f.display_white - f.display_black) * shown);
  }
  apply_shutter(out.display, f.shutter);

  if (f.bits > 0) {
    const double top = f.bits == 8 ? 255.0 : 65535.0;
    out.quantised = Image<std::uint16_t>(rows, cols);
    for (std::size_t p = 0; p < s.size(); ++p) {
      const double level = std::round(std::clamp(double(out.display.data()[p]), 0.0, 1.0) * top);
      out.quantised.data()[p] = static_cast<std::uint16_t>(level);
      out.display.data()[p] = static_cast<float>(level / top);
    }
  }
  return out;
}

/// The same from line integrals (optical depth, unitless): primary = exp(-line integral).
inline FormedAngiogram form_angiogram(const Image<float>& line_integrals, double pixel_mm,
                                      const AngiogramFormation& f, Rng& rng) {
  Image<float> primary(line_integrals.rows(), line_integrals.cols());
  for (std::size_t p = 0; p < primary.size(); ++p) {
    const float l = line_integrals.data()[p];
    GIMM_CHECK(std::isfinite(l) && l >= 0,
               "angiogram formation: line integrals must be finite "
               "and >= 0, got "
                   << l << " at pixel " << p);
    primary.data()[p] = std::exp(-l);
  }
  return form_angiogram_from_intensity(primary, pixel_mm, f, rng);
}

/// A closed interval [lo, hi] a parameter is drawn from (lo == hi: fixed).
struct Interval {
  double lo = 0, hi = 0;
};

/// Domain-randomisation ranges: each parameter is drawn uniformly in its interval, the dose
/// log-uniformly (noise goes as its square root, so each octave of dose is as likely). The
/// defaults span clinical cine acquisitions (docs/realism.md); drawn together, they put a 3 mm
/// vessel's contrast and CNR inside the clinical range for most draws, and near it for the
/// rest (weak iodine at a hard beam, strong scatter and a wide window all at once; measured in
/// tests/render/angiogram_formation_test.cpp).
struct AngiogramFormationRanges {
  Interval scatter_to_primary{0.3, 0.9};
  Interval scatter_sigma_mm{20, 80};
  Interval focal_spot_blur_px{0.2, 1.0};
  Interval detector_blur_px{0.4, 1.2};
  Interval detector_photons{2500, 12000};  ///< log-uniform
  Interval electronic_noise{0, 30};
  Interval range_compression{0.75, 0.9};
  Interval range_compression_sigma_px{16, 48};
  Interval edge_gain{0.3, 0.9};
  Interval edge_radius_px{1.5, 5};
  Interval window_min_width{0.65, 1.0};
  Interval gamma{0.85, 1.2};
  int bits = 8;  ///< fixed, not drawn
  /// Shutter shape weights (none, rectangular, octagonal, circular), >= 0, not all 0.
  double weight_none = 0.15, weight_rectangular = 0.5, weight_octagonal = 0.2,
         weight_circular = 0.15;
  /// Rectangle/octagon, each side drawn on its own. Real frames keep 0.90-0.97 of the image
  /// exposed (four clinical views; GE DL frames: an 8-10 px border at 512 px).
  Interval shutter_half_size{0.85, 1.05};
  Interval shutter_corner_cut{0.2, 0.5};
  Interval shutter_radius{1.0, 1.3};
  Interval shutter_center{-0.04, 0.04};  ///< u and v each
  Interval shutter_penumbra_px{2, 12};
  Interval shutter_frame_level{0.0, 0.12};
  Interval display_black{0.12, 0.3};
  Interval display_white{0.65, 0.9};

  /// Every interval ordered and inside the parameter's valid range; weights usable.
  void validate() const {
    const std::pair<const char*, Interval> all[] = {
        {"scatter_to_primary", scatter_to_primary},
        {"scatter_sigma_mm", scatter_sigma_mm},
        {"focal_spot_blur_px", focal_spot_blur_px},
        {"detector_blur_px", detector_blur_px},
        {"detector_photons", detector_photons},
        {"electronic_noise", electronic_noise},
        {"range_compression", range_compression},
        {"range_compression_sigma_px", range_compression_sigma_px},
        {"edge_gain", edge_gain},
        {"edge_radius_px", edge_radius_px},
        {"window_min_width", window_min_width},
        {"gamma", gamma},
        {"shutter_half_size", shutter_half_size},
        {"shutter_corner_cut", shutter_corner_cut},
        {"shutter_radius", shutter_radius},
        {"shutter_center", shutter_center},
        {"shutter_penumbra_px", shutter_penumbra_px},
        {"shutter_frame_level", shutter_frame_level},
        {"display_black", display_black},
        {"display_white", display_white}};
    for (const auto& [name, iv] : all)
      GIMM_CHECK(std::isfinite(iv.lo) && std::isfinite(iv.hi) && iv.lo <= iv.hi,
                 "angiogram formation ranges: " << name << " must be finite with lo <= hi, got ["
                                                << iv.lo << ", " << iv.hi << "]");
    GIMM_CHECK(detector_photons.lo > 0,
               "angiogram formation ranges: detector_photons must be > 0 (log-uniform), got ["
                   << detector_photons.lo << ", " << detector_photons.hi << "]");
    const double weights[] = {weight_none, weight_rectangular, weight_octagonal, weight_circular};
    double total = 0;
    for (double w : weights) {
      GIMM_CHECK(std::isfinite(w) && w >= 0,
                 "angiogram formation ranges: shutter weights must be finite and >= 0, got " << w);
      total += w;
    }
    GIMM_CHECK(total > 0, "angiogram formation ranges: the shutter weights are all 0");
    try {  // both ends of every interval must be valid parameters
      at(0).validate();
      at(1).validate();
    } catch (const Error& e) {
      std::string why = e.what();
      if (why.rfind("gimm: ", 0) == 0) why = why.substr(6);
      throw Error("gimm: angiogram formation ranges: an interval's end is out of range: " + why);
    }
  }

  /// The formation with every drawn parameter at fraction t of its interval (0: lo, 1: hi).
  AngiogramFormation at(double t) const {
    const auto x = [t](Interval iv) { return iv.lo + t * (iv.hi - iv.lo); };
    AngiogramFormation f;
    f.scatter_to_primary = x(scatter_to_primary);
    f.scatter_sigma_mm = x(scatter_sigma_mm);
    f.focal_spot_blur_px = x(focal_spot_blur_px);
    f.detector_blur_px = x(detector_blur_px);
    f.detector_photons = x(detector_photons);
    f.electronic_noise = x(electronic_noise);
    f.range_compression = x(range_compression);
    f.range_compression_sigma_px = x(range_compression_sigma_px);
    f.edge_gain = x(edge_gain);
    f.edge_radius_px = x(edge_radius_px);
    f.window_min_width = x(window_min_width);
    f.gamma = x(gamma);
    f.bits = bits;
    f.shutter.half_width = f.shutter.half_height = x(shutter_half_size);
    f.shutter.corner_cut = x(shutter_corner_cut);
    f.shutter.radius = x(shutter_radius);
    f.shutter.center_u = f.shutter.center_v = x(shutter_center);
    f.shutter.penumbra_px = x(shutter_penumbra_px);
    f.shutter.frame_level = x(shutter_frame_level);
    f.display_black = x(display_black);
    f.display_white = x(display_white);
    return f;
  }
};

/// One formation drawn from `ranges`, deterministic from `rng` (a fixed number of draws in a
/// fixed order, whatever the shape drawn: a view's other random choices do not shift).
inline AngiogramFormation randomize(const AngiogramFormationRanges& ranges, Rng& rng) {
  ranges.validate();
  const auto draw = [&rng](Interval iv) { return iv.lo + (iv.hi - iv.lo) * rng.uniform(); };
  AngiogramFormation f;
  f.scatter_to_primary = draw(ranges.scatter_to_primary);
  f.scatter_sigma_mm = draw(ranges.scatter_sigma_mm);
  f.focal_spot_blur_px = draw(ranges.focal_spot_blur_px);
  f.detector_blur_px = draw(ranges.detector_blur_px);
  f.detector_photons =
      std::exp(draw({std::log(ranges.detector_photons.lo), std::log(ranges.detector_photons.hi)}));
  f.electronic_noise = draw(ranges.electronic_noise);
  f.range_compression = draw(ranges.range_compression);
  f.range_compression_sigma_px = draw(ranges.range_compression_sigma_px);
  f.edge_gain = draw(ranges.edge_gain);
  f.edge_radius_px = draw(ranges.edge_radius_px);
  f.window_min_width = draw(ranges.window_min_width);
  f.gamma = draw(ranges.gamma);
  f.bits = ranges.bits;
  const double weights[] = {ranges.weight_none, ranges.weight_rectangular, ranges.weight_octagonal,
                            ranges.weight_circular};
  double pick = rng.uniform() * (weights[0] + weights[1] + weights[2] + weights[3]);
  int shape = 0;
  while (shape < 3 && (weights[shape] == 0 || pick >= weights[shape])) pick -= weights[shape++];
  while (weights[shape] == 0) --shape;  // rounding past the last shape with weight
  f.shutter.shape = static_cast<ShutterShape>(shape);
  f.shutter.half_width = draw(ranges.shutter_half_size);
  f.shutter.half_height = draw(ranges.shutter_half_size);
  f.shutter.corner_cut = draw(ranges.shutter_corner_cut);
  f.shutter.radius = draw(ranges.shutter_radius);
  f.shutter.center_u = draw(ranges.shutter_center);
  f.shutter.center_v = draw(ranges.shutter_center);
  f.shutter.penumbra_px = draw(ranges.shutter_penumbra_px);
  f.shutter.frame_level = draw(ranges.shutter_frame_level);
  f.display_black = draw(ranges.display_black);  // last: the draws before keep their order
  f.display_white = draw(ranges.display_white);
  f.validate();
  return f;
}

/// Ranges of the injection's contrast (render/iodine.hpp), drawn per patient and system where
/// the attenuation is built: about half-diluted 300-370 mgI/mL contrast, 70-90 kVp beams.
struct IodineContrastRanges {
  Interval iodine_mg_per_ml{140, 240};
  Interval effective_kev{50, 66};

  void validate() const {
    for (const auto& [name, iv] :
         {std::pair<const char*, Interval>{"iodine_mg_per_ml", iodine_mg_per_ml},
          {"effective_kev", effective_kev}})
      GIMM_CHECK(std::isfinite(iv.lo) && std::isfinite(iv.hi) && iv.lo <= iv.hi,
                 "iodine contrast ranges: " << name << " must be finite with lo <= hi, got ["
                                            << iv.lo << ", " << iv.hi << "]");
    IodineContrast lo{iodine_mg_per_ml.lo, effective_kev.lo};
    IodineContrast hi{iodine_mg_per_ml.hi, effective_kev.hi};
    lo.validate();
    hi.validate();
  }
};

/// One contrast drawn from `ranges` (two draws), deterministic from `rng`.
inline IodineContrast randomize(const IodineContrastRanges& ranges, Rng& rng) {
  ranges.validate();
  IodineContrast c;
  c.iodine_mg_per_ml = ranges.iodine_mg_per_ml.lo +
                       (ranges.iodine_mg_per_ml.hi - ranges.iodine_mg_per_ml.lo) * rng.uniform();
  c.effective_kev =
      ranges.effective_kev.lo + (ranges.effective_kev.hi - ranges.effective_kev.lo) * rng.uniform();
  return c;
}

}  // namespace gimm
