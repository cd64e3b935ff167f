#pragma once
/// Vessels from an angiogram alone: the background removed (log intensity, black top-hat),
/// multi-scale Hessian vesselness (Frangi et al. 1998) and a segmentation by hysteresis
/// threshold with small components removed.
///
/// Contrast-filled vessels are dark on a brighter background, so across a vessel the intensity
/// has a minimum: the Hessian's larger-magnitude eigenvalue l2 is positive there. At scale s
/// (Gaussian sigma, pixels) with s^2-normalised derivatives and |l1| <= |l2|:
///   V_s = 0 when l2 <= 0, else exp(-Rb^2 / (2 beta^2)) (1 - exp(-S^2 / (2 c^2))),
///   Rb = l1 / l2 (blob against line), S = sqrt(l1^2 + l2^2) (structure against noise).
/// V is the maximum over scales; c is half the largest S over the image and scales (Frangi's
/// rule), so V does not depend on the image's intensity scale.
///
/// A bar of half-width r pixels (a box profile) answers best at s = r: its s^2-normalised second
/// derivative at the centre is 2 r G(r; s), largest at s = r. vessel_scales() maps coronary radii
/// in mm to scales through the detector's magnification, so the same settings serve 256 and 512 px
/// images.
///
/// Two ways to the Hessian at each scale (VesselnessOptions::exact_derivatives), with the same
/// sampled Gaussian-derivative kernels:
/// - fast (the default): float, border-padded passes whose loops vectorise, and scales of
///   half_resolution_from_px and more on the image averaged over 2x2 blocks;
/// - exact (the reference): double, every scale at full resolution.
/// (3-point differences of a blurred image were tried first: 2x cheaper again, but they cost the
/// segmented geometric matcher 0.06 Prec@3px on 24 held-out phantoms.)
#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/core/filter.hpp"
#include "gimm/core/image.hpp"
#include "gimm/core/morphology.hpp"

namespace gimm {

struct VesselnessOptions {
  std::vector<double> scales_px = {1.0, 1.5, 2.0, 3.0};  ///< Gaussian sigmas, pixels
  double beta = 0.5;                                     ///< Rb weight (Frangi's 0.5)
  bool exact_derivatives = false;  ///< the slow reference path (sampled derivative kernels)
  /// Fast path: scales of at least this many pixels run on the image averaged over 2x2 blocks,
  /// at half the scale (a quarter of the work; a vessel that wide is still >= 2 px wide there),
  /// and their response is interpolated back. 0: every scale at full resolution.
  double half_resolution_from_px = 1.9;
};

struct SegmentationOptions {
  VesselnessOptions vesselness;
  /// Before the vesselness, the background goes (vessel_contrast()): the log of the intensity,
  /// then the black top-hat over a window just wider than the widest vessel looked for. Ribs,
  /// spine and the edges of body and table are wider than that, or are steps; the Hessian alone
  /// answers to them (on the phantom, 9 of 10 segmented pixels were not vessel without this).
  bool remove_background = true;
  // Thresholds chosen with the geometric matcher on the tuning set (8 phantom patients, seed 11;
  // docs/geometric-matcher.md): a low `low` grows the faint distal vessels back from their seeds.
  double high = 0.05;    ///< seeds: V >= high (V is in [0, 1])
  double low = 0.002;    ///< grown from seeds through V >= low (8-connected)
  int min_area_px = 30;  ///< components smaller than this are removed
  /// With an exposed field: the band inside its edge that is treated as outside (a shutter's
  /// penumbra, darker than the field, would be a line along the edge), pixels.
  int field_edge_px = 5;
};

/// Scales for vessel radii `radius_mm` (lumen radii of coronary arteries, 0.75-2 mm by default)
/// seen at `px_per_mm` detector pixels per mm at the vessels (focal length / depth).
inline std::vector<double> vessel_scales(double px_per_mm, const std::vector<double>& radius_mm = {
                                                               0.75, 1.1, 1.5, 2.0}) {
  GIMM_CHECK(std::isfinite(px_per_mm) && px_per_mm > 0,
             "vessel_scales: pixels per mm must be finite and > 0, got " << px_per_mm);
  std::vector<double> scales;
  for (double r : radius_mm) {
    GIMM_CHECK(std::isfinite(r) && r > 0, "vessel_scales: radius must be > 0 mm, got " << r);
    scales.push_back(std::max(0.7, r * px_per_mm));
  }
  return scales;
}

namespace detail {

/// Separable convolution: `along_cols` runs along each row (x = u), `along_rows` along each
/// column (y = v); borders replicate the edge pixel.
inline Image<float> convolve_separable(const Image<float>& in, const std::vector<double>& along_x,
                                       const std::vector<double>& along_y) {
  const int rows = in.rows(), cols = in.cols();
  const int hx = static_cast<int>(along_x.size() / 2), hy = static_cast<int>(along_y.size() / 2);
  Image<float> tmp(rows, cols), out(rows, cols);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      double s = 0;
      for (int k = -hx; k <= hx; ++k)
        s += along_x[static_cast<std::size_t>(k + hx)] * in(r, std::clamp(c - k, 0, cols - 1));
      tmp(r, c) = static_cast<float>(s);
    }
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      double s = 0;
      for (int k = -hy; k <= hy; ++k)
        s += along_y[static_cast<std::size_t>(k + hy)] * tmp(std::clamp(r - k, 0, rows - 1), c);
      out(r, c) = static_cast<float>(s);
    }
  return out;
}

/// The eigenvalues of the s^2-normalised Hessian at one scale, |l1| <= |l2| at each pixel.
struct ScaleEigen {
  Image<float> l1, l2;
};

inline void eigen_2x2(float xx, float xy, float yy, float& l1, float& l2) {
  const float mean = 0.5f * (xx + yy);
  const float root = std::sqrt(0.25f * (xx - yy) * (xx - yy) + xy * xy);
  l1 = mean - root;
  l2 = mean + root;
  if (std::abs(l1) > std::abs(l2)) std::swap(l1, l2);
}

/// The eigenvalues of the Hessian (xx, xy, yy) at scale s, s^2-normalised: eigen_2x2() at every
/// pixel, in two passes that vectorise: Eigen's packet square root (within a few ulp of the
/// scalar one; it has no overflow guard, so Hessian entries past about 1e19 would give NaN where
/// the scalar rule gives infinities: far beyond any image's), then the pair ordered by magnitude
/// without a branch (|mean - root| > |mean + root| when mean < 0 and root > 0; equal otherwise).
inline void scale_eigen(const Image<float>& xx, const Image<float>& xy, const Image<float>& yy,
                        double s, ScaleEigen& e) {
  e.l1.resize(xx.rows(), xx.cols());
  e.l2.resize(xx.rows(), xx.cols());
  const float n = static_cast<float>(s * s);
  const auto size = static_cast<Eigen::Index>(xx.size());
  const Eigen::Map<const Eigen::ArrayXf> a(xx.data(), size), b(xy.data(), size), c(yy.data(), size);
  Eigen::Map<Eigen::ArrayXf> root(e.l2.data(), size);
  root = ((0.25f * (n * a - n * c)) * (n * a - n * c) + (n * b) * (n * b)).sqrt();
  float *l1 = e.l1.data(), *l2 = e.l2.data();
  const float *pa = xx.data(), *pc = yy.data();
  for (std::size_t i = 0; i < xx.size(); ++i) {
    const float mean = 0.5f * (n * pa[i] + n * pc[i]);
    const float toward = mean < 0 ? -l2[i] : l2[i];  // l2 holds the root here
    l1[i] = mean - toward;
    l2[i] = mean + toward;
  }
}

/// The fast path's derivative images, reused from scale to scale (and call to call).
struct DerivativeBuffers {
  std::array<Image<float>, 3> along_x;  // the image convolved along x with G, G', G''
  Image<float> xx, xy, yy;
};

/// Reference: sampled Gaussian-derivative kernels, one set per scale, into `out[scale]`.
inline void eigen_exact(const Image<float>& image, const std::vector<double>& scales,
                        std::vector<ScaleEigen>& out) {
  out.resize(scales.size());
  for (std::size_t i = 0; i < scales.size(); ++i) {
    const double s = scales[i];
    const auto g0 = gaussian_kernel(s, 0), g1 = gaussian_kernel(s, 1), g2 = gaussian_kernel(s, 2);
    scale_eigen(convolve_separable(image, g2, g0), convolve_separable(image, g1, g1),
                convolve_separable(image, g0, g2), s, out[i]);
  }
}

/// Fast: the reference's sampled Gaussian-derivative kernels, applied in float by the
/// vectorising passes above (three row passes shared by the three second derivatives).
inline void eigen_fast(const Image<float>& image, const std::vector<double>& scales,
                       DerivativeBuffers& d, std::vector<ScaleEigen>& out) {
  out.resize(scales.size());
  for (std::size_t i = 0; i < scales.size(); ++i) {
    std::array<std::vector<float>, 3> g;
    for (int order = 0; order < 3; ++order) {
      const std::vector<double> k = gaussian_kernel(scales[i], order);
      g[static_cast<std::size_t>(order)].assign(k.begin(), k.end());
    }
    for (std::size_t order = 0; order < 3; ++order)
      convolve_rows(image, g[order], d.along_x[order]);
    convolve_cols(d.along_x[2], g[0], d.xx);
    convolve_cols(d.along_x[1], g[1], d.xy);
    convolve_cols(d.along_x[0], g[2], d.yy);
    scale_eigen(d.xx, d.xy, d.yy, scales[i], out[i]);
  }
}

/// The largest structure norm S = |(l1, l2)| over pixels and scales.
inline double max_structure(const std::vector<ScaleEigen>& eigen) {
  float s2 = 0;
  for (const ScaleEigen& e : eigen)
    for (std::size_t i = 0; i < e.l1.size(); ++i)
      s2 = std::max(s2, e.l1.data()[i] * e.l1.data()[i] + e.l2.data()[i] * e.l2.data()[i]);
  return std::sqrt(static_cast<double>(s2));
}

/// Frangi's response into `v` (rows x cols), the maximum over scales, with Frangi's c given.
inline void frangi_max(const std::vector<ScaleEigen>& eigen, int rows, int cols, double beta,
                       double c, Image<float>& v) {
  v.assign(rows, cols, 0.0f);
  const float rb_weight = static_cast<float>(1 / (2 * beta * beta));
  const float s_weight = static_cast<float>(1 / (2 * c * c));
  for (const ScaleEigen& e : eigen)
    for (std::size_t i = 0; i < v.size(); ++i) {
      const float l1 = e.l1.data()[i], l2 = e.l2.data()[i];
      if (!(l2 > 0)) continue;  // bright structures and flat ground
      const float rb = l1 / l2, s2 = l1 * l1 + l2 * l2;
      const float value = std::exp(-rb * rb * rb_weight) * (1 - std::exp(-s2 * s_weight));
      v.data()[i] = std::max(v.data()[i], value);
    }
}

/// The image averaged over 2x2 blocks into `out` (an odd last row or column averages what it
/// has).
inline void half_size(const Image<float>& in, Image<float>& out) {
  const int rows = (in.rows() + 1) / 2, cols = (in.cols() + 1) / 2;
  out.resize(rows, cols);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      const int r1 = std::min(2 * r + 1, in.rows() - 1), c1 = std::min(2 * c + 1, in.cols() - 1);
      out(r, c) = 0.25f * (in(2 * r, 2 * c) + in(2 * r, c1) + in(r1, 2 * c) + in(r1, c1));
    }
}

/// full = max(full, `half` interpolated back): bilinear, pixel centres aligned (full-resolution
/// pixel r sits at half-resolution coordinate r / 2 - 0.25), borders clamped.
inline void max_with_doubled(Image<float>& full, const Image<float>& half) {
  struct Axis {
    int lo, hi;
    float w;  // weight of hi
  };
  const auto axis = [](int n_full, int n_half) {
    std::vector<Axis> out(static_cast<std::size_t>(n_full));
    for (int i = 0; i < n_full; ++i) {
      const double x = std::clamp(0.5 * i - 0.25, 0.0, double(n_half - 1));
      const int lo = std::min(static_cast<int>(x), n_half - 1);
      out[static_cast<std::size_t>(i)] = {lo, std::min(lo + 1, n_half - 1),
                                          static_cast<float>(x - lo)};
    }
    return out;
  };
  const std::vector<Axis> ra = axis(full.rows(), half.rows()), ca = axis(full.cols(), half.cols());
  for (int r = 0; r < full.rows(); ++r) {
    const auto [r0, r1, wr] = ra[static_cast<std::size_t>(r)];
    for (int c = 0; c < full.cols(); ++c) {
      const auto [c0, c1, wc] = ca[static_cast<std::size_t>(c)];
      const float top = half(r0, c0) + wc * (half(r0, c1) - half(r0, c0));
      const float bottom = half(r1, c0) + wc * (half(r1, c1) - half(r1, c0));
      full(r, c) = std::max(full(r, c), top + wr * (bottom - top));
    }
  }
}

}  // namespace detail

namespace detail {

inline void check_vesselness_options(const VesselnessOptions& o) {
  GIMM_CHECK(!o.scales_px.empty(), "vesselness: no scales given");
  GIMM_CHECK(std::isfinite(o.beta) && o.beta > 0, "vesselness: beta must be > 0, got " << o.beta);
  for (double s : o.scales_px)
    GIMM_CHECK(std::isfinite(s) && s >= 0.5 && s <= 64,
               "vesselness: scale must be in [0.5, 64] px, got " << s);
  GIMM_CHECK(o.half_resolution_from_px == 0 ||
                 (std::isfinite(o.half_resolution_from_px) && o.half_resolution_from_px >= 1),
             "vesselness: half_resolution_from_px must be 0 (off) or >= 1 px, got "
                 << o.half_resolution_from_px);
}

}  // namespace detail

/// The working images of vesselness(), for a caller that keeps them between calls: at one
/// image size they are allocated once (about 10 MB at 512 x 512 px).
struct VesselnessBuffers {
  detail::DerivativeBuffers derivatives;
  std::vector<detail::ScaleEigen> full, half;  // per scale, at full and at half resolution
  Image<float> halved, half_response;
};

/// Vesselness in [0, 1] of dark tubular structures into `v` (resized); image intensities in any
/// range.
inline void vesselness(const Image<float>& image, const VesselnessOptions& o, Image<float>& v,
                       VesselnessBuffers& buffers) {
  GIMM_CHECK(!image.empty(), "vesselness: the image is empty");
  GIMM_CHECK(&image != &v, "vesselness: the output image must not be the input");
  detail::check_vesselness_options(o);
  for (float x : image.storage())
    GIMM_CHECK(std::isfinite(x), "vesselness: the image has a non-finite pixel (" << x << ")");
  std::vector<double> full_scales, half_scales;  // half: in half-resolution pixels
  const bool halve = !o.exact_derivatives && o.half_resolution_from_px > 0 &&
                     std::min(image.rows(), image.cols()) >= 16;
  for (double s : o.scales_px) {
    if (halve && s >= o.half_resolution_from_px)  // less the 2x2 mean's own blur (0.25 px)
      half_scales.push_back(std::sqrt(0.25 * s * s - 0.0625));
    else
      full_scales.push_back(s);
  }
  auto eigen = [&](const Image<float>& im, const std::vector<double>& scales,
                   std::vector<detail::ScaleEigen>& out) {
    if (o.exact_derivatives)
      detail::eigen_exact(im, scales, out);
    else
      detail::eigen_fast(im, scales, buffers.derivatives, out);
  };
  std::vector<detail::ScaleEigen>&full = buffers.full, &half = buffers.half;
  eigen(image, full_scales, full);
  if (!half_scales.empty()) detail::half_size(image, buffers.halved);
  eigen(buffers.halved, half_scales, half);  // no scales: `half` is emptied
  // Frangi's c: half the largest structure norm over the image and all scales.
  const double s_max = std::max(detail::max_structure(full), detail::max_structure(half));
  if (!(s_max > 0)) {  // no structure
    v.assign(image.rows(), image.cols(), 0.0f);
    return;
  }
  const double c = 0.5 * s_max;
  detail::frangi_max(full, image.rows(), image.cols(), o.beta, c, v);
  if (!half.empty()) {
    const Image<float>& halved = buffers.halved;
    detail::frangi_max(half, halved.rows(), halved.cols(), o.beta, c, buffers.half_response);
    detail::max_with_doubled(v, buffers.half_response);
  }
  // Normalise to the image's strongest response, so thresholds are relative.
  const float top = *std::max_element(v.storage().begin(), v.storage().end());
  if (top > 0)
    for (float& x : v.storage()) x /= top;
}

inline Image<float> vesselness(const Image<float>& image, const VesselnessOptions& o = {}) {
  Image<float> v;
  VesselnessBuffers buffers;
  vesselness(image, o, v, buffers);
  return v;
}

/// The closing's window for scales up to `largest_scale_px`: the narrowest odd width wider than
/// the widest vessel looked for (a bar of half-width r answers best at scale r).
inline int background_width_px(double largest_scale_px) {
  return 2 * static_cast<int>(std::ceil(largest_scale_px)) + 1;
}

/// The vessels of an angiogram (dark on brighter ground, intensities in any range) without its
/// background, still dark on flat ground (0), ready for vesselness(). X-ray intensity is
/// exp(-line integral), so in its log a vessel's contrast does not depend on the bone or tissue
/// behind it; the black top-hat of the log over `width` keeps the dark structures narrower than
/// the window (the vessels) and drops wider ones and steps. The log is taken of the image scaled
/// to [0, 1], plus 1e-3 (a window's black is not zero intensity, and a floor keeps it finite).
inline void vessel_contrast(const Image<float>& image, int width, Image<float>& contrast,
                            Image<float>& log_image, TopHatBuffers& buffers) {
  GIMM_CHECK(!image.empty(), "vessel_contrast: the image is empty");
  GIMM_CHECK(&image != &contrast && &image != &log_image,
             "vessel_contrast: the output images must not be the input");
  float lo = std::numeric_limits<float>::infinity(), hi = -lo;
  for (float v : image.storage()) {
    GIMM_CHECK(std::isfinite(v), "vessel_contrast: the image has a non-finite pixel (" << v << ")");
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  if (!(hi > lo)) {  // flat: nothing to find
    contrast.assign(image.rows(), image.cols(), 0.0f);
    return;
  }
  const float scale = 1.0f / (hi - lo);
  log_image.resize(image.rows(), image.cols());
  using Pixels = Eigen::Map<Eigen::ArrayXf>;
  const Eigen::Map<const Eigen::ArrayXf> in(image.data(), static_cast<Eigen::Index>(image.size()));
  Pixels(log_image.data(), in.size()) = ((in - lo) * scale + 1e-3f).log();  // Eigen's packet log
  black_top_hat(log_image, width, contrast, buffers);
  for (float& v : contrast.storage()) v = -v;
}

inline Image<float> vessel_contrast(const Image<float>& image, int width) {
  Image<float> contrast, log_image;
  TopHatBuffers buffers;
  vessel_contrast(image, width, contrast, log_image, buffers);
  return contrast;
}

/// The working memory of segment_vessels(), for a caller that segments image after image (a
/// matcher, pair after pair): kept, it is allocated once per image size. On machines where the
/// first touch of a page is dear (a virtual machine's), allocating it afresh for each 512 x 512
/// image took as long as the segmentation's arithmetic.
struct SegmentationBuffers {
  Image<float> log_image, contrast, response, filled;
  Image<std::uint8_t> inside;  // with a field: where the image is kept
  Image<int> field_counts;
  TopHatBuffers top_hat;
  VesselnessBuffers vesselness;
  Image<std::uint8_t> seen;
  std::vector<int> component, frontier;  // frontier: a stack (the component is the same)
};

namespace detail {
/// `inside`: 1 where `field` is 1 and so is every pixel within `edge_px` (a square window);
/// `filled`: `image` with the other pixels filled from the nearest of these (see below).
/// `column_out` is working memory.
inline void fill_outside_field(const Image<float>& image, const Image<std::uint8_t>& field,
                               int edge_px, Image<float>& filled, Image<std::uint8_t>& inside,
                               Image<int>& column_out) {
  GIMM_CHECK(field.rows() == image.rows() && field.cols() == image.cols(),
             "segment_vessels: the field is " << field.cols() << " x " << field.rows()
                                              << ", the image " << image.cols() << " x "
                                              << image.rows());
  const int rows = image.rows(), cols = image.cols();
  // Pixels outside the field in each column's window of 2 edge_px + 1 rows (running count),
  // then in each row's window of those counts. Beyond the image counts as inside: a field that
  // reaches the image's edge (no shutter there) keeps its pixels up to it.
  column_out.resize(rows, cols);
  for (int c = 0; c < cols; ++c) {
    auto out = [&](int r) { return r >= 0 && r < rows && !field(r, c) ? 1 : 0; };
    int count = 0;
    for (int r = -edge_px; r <= edge_px; ++r) count += out(r);
    for (int r = 0; r < rows; ++r) {
      column_out(r, c) = count;
      count += out(r + edge_px + 1) - out(r - edge_px);
    }
  }
  inside.assign(rows, cols, 0);
  for (int r = 0; r < rows; ++r) {
    auto out = [&](int c) { return c >= 0 && c < cols ? column_out(r, c) : 0; };
    int count = 0;
    for (int c = -edge_px; c <= edge_px; ++c) count += out(c);
    for (int c = 0; c < cols; ++c) {
      if (count == 0) inside(r, c) = 1;
      count += out(c + edge_px + 1) - out(c - edge_px);
    }
  }
  // Outside pixels take the value of the nearest kept pixel of their row; rows with none, that
  // of the nearest row that has one. The image continues flat across the field's edge: no step
  // or line there for the vesselness to answer to (a constant fill made the vignette inside
  // the edge a dark line along it).
  filled = image;
  int last_kept_row = -1;
  for (int r = 0; r < rows; ++r) {
    int prev = -1;
    for (int c = 0; c < cols; ++c) {
      if (!inside(r, c)) continue;
      const int from = prev < 0 ? 0 : (prev + c + 1) / 2;  // the gap's nearer half from c
      for (int k = from; k < c; ++k) filled(r, k) = image(r, c);
      if (prev >= 0)
        for (int k = prev + 1; k < from; ++k) filled(r, k) = image(r, prev);
      prev = c;
    }
    if (prev < 0) continue;  // no kept pixel: from the nearest row that has one, below
    for (int k = prev + 1; k < cols; ++k) filled(r, k) = image(r, prev);
    // Rows above without a kept pixel: their nearer half from this row, the rest from the last.
    const int from = last_kept_row < 0 ? 0 : (last_kept_row + r + 1) / 2;
    for (int rr = from; rr < r; ++rr)
      for (int c = 0; c < cols; ++c) filled(rr, c) = filled(r, c);
    if (last_kept_row >= 0)
      for (int rr = last_kept_row + 1; rr < from; ++rr)
        for (int c = 0; c < cols; ++c) filled(rr, c) = filled(last_kept_row, c);
    last_kept_row = r;
  }
  if (last_kept_row < 0) {  // nothing kept: flat
    filled.assign(rows, cols, 0.0f);
    return;
  }
  for (int rr = last_kept_row + 1; rr < rows; ++rr)
    for (int c = 0; c < cols; ++c) filled(rr, c) = filled(last_kept_row, c);
}
}  // namespace detail

/// A vessel mask (1 = vessel) from an angiogram: background removed (SegmentationOptions::
/// remove_background), vesselness, hysteresis, small components removed. An image without
/// vessel-like structure gives an empty mask.
///
/// With the exposed `field` (field_of_view.hpp), what lies outside it and within
/// SegmentationOptions::field_edge_px of its edge is first filled from the nearest pixel kept
/// (along its row, or the nearest row), and the mask is cleared there. Otherwise a thin strip of
/// collimator along the image's edge is the strongest "vessel" of all, and vesselness, normalised
/// to its strongest response, leaves the real vessels below the thresholds: one clinical-style view
/// kept 31 vessel pixels.
inline void segment_vessels(const Image<float>& image, const SegmentationOptions& o,
                            Image<std::uint8_t>& mask, SegmentationBuffers& buffers,
                            const Image<std::uint8_t>* field = nullptr) {
  if (field) {
    GIMM_CHECK(o.field_edge_px >= 0 && o.field_edge_px <= 64,
               "segment_vessels: field_edge_px must be in [0, 64], got " << o.field_edge_px);
    detail::fill_outside_field(image, *field, o.field_edge_px, buffers.filled, buffers.inside,
                               buffers.field_counts);
    segment_vessels(buffers.filled, o, mask, buffers);
    for (std::size_t k = 0; k < mask.size(); ++k)
      if (!buffers.inside.data()[k]) mask.data()[k] = 0;
    return;
  }
  GIMM_CHECK(
      o.low > 0 && o.high >= o.low && o.high <= 1,
      "segment_vessels: need 0 < low <= high <= 1, got low " << o.low << ", high " << o.high);
  GIMM_CHECK(o.min_area_px >= 0,
             "segment_vessels: min_area_px must be >= 0, got " << o.min_area_px);
  detail::check_vesselness_options(o.vesselness);
  const std::vector<double>& scales = o.vesselness.scales_px;
  const double widest = *std::max_element(scales.begin(), scales.end());
  Image<float>& v = buffers.response;
  if (o.remove_background && !image.empty()) {
    vessel_contrast(image, background_width_px(widest), buffers.contrast, buffers.log_image,
                    buffers.top_hat);
    vesselness(buffers.contrast, o.vesselness, v, buffers.vesselness);
  } else {
    vesselness(image, o.vesselness, v, buffers.vesselness);
  }
  const int rows = v.rows(), cols = v.cols();
  mask.assign(rows, cols, 0);
  Image<std::uint8_t>& seen = buffers.seen;
  seen.assign(rows, cols, 0);
  std::vector<int>&component = buffers.component, &frontier = buffers.frontier;
  for (int start = 0; start < rows * cols; ++start) {
    if (seen.data()[start] || v.data()[start] < o.low) continue;
    // One 8-connected component of V >= low; kept if it holds a seed and is large enough.
    component.clear();
    bool seeded = false;
    frontier.push_back(start);
    seen.data()[start] = 1;
    while (!frontier.empty()) {
      const int p = frontier.back();
      frontier.pop_back();
      component.push_back(p);
      seeded = seeded || v.data()[p] >= o.high;
      const int r = p / cols, c = p % cols;
      for (int dr = -1; dr <= 1; ++dr)
        for (int dc = -1; dc <= 1; ++dc) {
          const int rr = r + dr, cc = c + dc;
          if (!mask.contains(rr, cc)) continue;
          const int q = rr * cols + cc;
          if (seen.data()[q] || v.data()[q] < o.low) continue;
          seen.data()[q] = 1;
          frontier.push_back(q);
        }
    }
    if (seeded && static_cast<int>(component.size()) >= o.min_area_px)
      for (int p : component) mask.data()[p] = 1;
  }
}

inline Image<std::uint8_t> segment_vessels(const Image<float>& image,
                                           const SegmentationOptions& o = {},
                                           const Image<std::uint8_t>* field = nullptr) {
  Image<std::uint8_t> mask;
  SegmentationBuffers buffers;
  segment_vessels(image, o, mask, buffers, field);
  return mask;
}

}  // namespace gimm
