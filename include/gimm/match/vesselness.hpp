#pragma once
/// Vessels from an angiogram alone: multi-scale Hessian vesselness (Frangi et al. 1998) and a
/// segmentation by hysteresis threshold with small components removed.
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
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <queue>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/core/image.hpp"

namespace gimm {

struct VesselnessOptions {
  std::vector<double> scales_px = {1.0, 1.5, 2.0, 3.0};  ///< Gaussian sigmas, pixels
  double beta = 0.5;                                     ///< Rb weight (Frangi's 0.5)
};

struct SegmentationOptions {
  VesselnessOptions vesselness;
  double high = 0.15;    ///< seeds: V >= high (V is in [0, 1])
  double low = 0.05;     ///< grown from seeds through V >= low (8-connected)
  int min_area_px = 30;  ///< components smaller than this are removed
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

/// Sampled Gaussian derivative of order 0, 1 or 2 at sigma, truncated at 4 sigma.
inline std::vector<double> gaussian_kernel(double sigma, int order) {
  const int half = static_cast<int>(std::ceil(4 * sigma));
  std::vector<double> k(static_cast<std::size_t>(2 * half + 1));
  double sum = 0;
  for (int x = -half; x <= half; ++x) sum += std::exp(-0.5 * x * x / (sigma * sigma));
  for (int x = -half; x <= half; ++x) {
    const double g = std::exp(-0.5 * x * x / (sigma * sigma)) / sum;
    const double s2 = sigma * sigma;
    k[static_cast<std::size_t>(x + half)] = order == 0   ? g
                                            : order == 1 ? -x / s2 * g
                                                         : (x * x - s2) / (s2 * s2) * g;
  }
  return k;
}

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

}  // namespace detail

/// The Hessian's eigenvalues at one pixel, ordered |l1| <= |l2|.
inline Eigen::Vector2d hessian_eigenvalues(double hxx, double hxy, double hyy) {
  const double mean = 0.5 * (hxx + hyy);
  const double root = std::sqrt(0.25 * (hxx - hyy) * (hxx - hyy) + hxy * hxy);
  double l1 = mean - root, l2 = mean + root;
  if (std::abs(l1) > std::abs(l2)) std::swap(l1, l2);
  return {l1, l2};
}

/// Vesselness in [0, 1] of dark tubular structures; image intensities in any range.
inline Image<float> vesselness(const Image<float>& image, const VesselnessOptions& o = {}) {
  GIMM_CHECK(!image.empty(), "vesselness: the image is empty");
  GIMM_CHECK(!o.scales_px.empty(), "vesselness: no scales given");
  GIMM_CHECK(std::isfinite(o.beta) && o.beta > 0, "vesselness: beta must be > 0, got " << o.beta);
  for (float v : image.storage())
    GIMM_CHECK(std::isfinite(v), "vesselness: the image has a non-finite pixel (" << v << ")");
  struct Scale {
    Image<float> l1, l2;
  };
  std::vector<Scale> per_scale;
  double s_max = 0;
  for (double s : o.scales_px) {
    GIMM_CHECK(std::isfinite(s) && s >= 0.5 && s <= 64,
               "vesselness: scale must be in [0.5, 64] px, got " << s);
    const auto g0 = detail::gaussian_kernel(s, 0), g1 = detail::gaussian_kernel(s, 1),
               g2 = detail::gaussian_kernel(s, 2);
    const Image<float> hxx = detail::convolve_separable(image, g2, g0);
    const Image<float> hyy = detail::convolve_separable(image, g0, g2);
    const Image<float> hxy = detail::convolve_separable(image, g1, g1);
    Scale sc{Image<float>(image.rows(), image.cols()), Image<float>(image.rows(), image.cols())};
    for (std::size_t i = 0; i < image.size(); ++i) {
      const double n = s * s;  // scale normalisation
      const Eigen::Vector2d l =
          hessian_eigenvalues(n * hxx.data()[i], n * hxy.data()[i], n * hyy.data()[i]);
      sc.l1.data()[i] = static_cast<float>(l.x());
      sc.l2.data()[i] = static_cast<float>(l.y());
      s_max = std::max(s_max, l.norm());
    }
    per_scale.push_back(std::move(sc));
  }
  Image<float> v(image.rows(), image.cols(), 0.0f);
  if (!(s_max > 0)) return v;  // a constant image has no structure
  const double c = 0.5 * s_max;
  for (const Scale& sc : per_scale)
    for (std::size_t i = 0; i < image.size(); ++i) {
      const double l1 = sc.l1.data()[i], l2 = sc.l2.data()[i];
      if (!(l2 > 0)) continue;
      const double rb = l1 / l2, s2 = l1 * l1 + l2 * l2;
      const double value =
          std::exp(-rb * rb / (2 * o.beta * o.beta)) * (1 - std::exp(-s2 / (2 * c * c)));
      v.data()[i] = std::max(v.data()[i], static_cast<float>(value));
    }
  // Normalise to the image's strongest response, so thresholds are relative.
  const float top = *std::max_element(v.storage().begin(), v.storage().end());
  if (top > 0)
    for (float& x : v.storage()) x /= top;
  return v;
}

/// A vessel mask (1 = vessel) from an angiogram: vesselness, hysteresis, small components
/// removed. An image without vessel-like structure gives an empty mask.
inline Image<std::uint8_t> segment_vessels(const Image<float>& image,
                                           const SegmentationOptions& o = {}) {
  GIMM_CHECK(
      o.low > 0 && o.high >= o.low && o.high <= 1,
      "segment_vessels: need 0 < low <= high <= 1, got low " << o.low << ", high " << o.high);
  GIMM_CHECK(o.min_area_px >= 0,
             "segment_vessels: min_area_px must be >= 0, got " << o.min_area_px);
  const Image<float> v = vesselness(image, o.vesselness);
  const int rows = v.rows(), cols = v.cols();
  Image<std::uint8_t> mask(rows, cols, 0);
  std::vector<int> component;
  std::queue<int> frontier;
  Image<std::uint8_t> seen(rows, cols, 0);
  for (int start = 0; start < rows * cols; ++start) {
    if (seen.data()[start] || v.data()[start] < o.low) continue;
    // One 8-connected component of V >= low; kept if it holds a seed and is large enough.
    component.clear();
    bool seeded = false;
    frontier.push(start);
    seen.data()[start] = 1;
    while (!frontier.empty()) {
      const int p = frontier.front();
      frontier.pop();
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
          frontier.push(q);
        }
    }
    if (seeded && static_cast<int>(component.size()) >= o.min_area_px)
      for (int p : component) mask.data()[p] = 1;
  }
  return mask;
}

}  // namespace gimm
