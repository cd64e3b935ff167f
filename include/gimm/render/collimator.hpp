#pragma once
/// Collimator shutters: the lead blades of a C-arm that limit the exposed field, seen on every
/// clinical frame as a dark frame with a blurred (penumbra) edge. Rectangular (the two pairs of
/// straight blades), octagonal (straight blades plus the wedge pairs cutting the corners) and
/// circular (the iris, and the round field of an image intensifier).
///
/// Geometry in pixels (col u, row v, centres at integers): the field is centred on the image
/// centre ((cols - 1) / 2, (rows - 1) / 2) moved by (center_u cols, center_v rows). Sizes are
/// fractions of the image so one shutter fits any detector size: rectangle half sizes
/// half_width cols / 2 and half_height rows / 2 (above 1 that edge lies outside the image);
/// the octagon is that rectangle with each corner cut by a 45-degree blade that removes
/// corner_cut min(half sizes) along both edges; the circle has radius radius min(rows, cols) / 2.
///
/// The edge: a pixel at signed distance d from the field edge (positive inside, px) is exposed
/// by the fraction Phi(d / s) (Phi the normal CDF), s = penumbra_px / 2.563: penumbra_px is the
/// 10%-90% width of the edge, as penumbra is measured. The exposed-field mask (for labels and
/// matchers) is the half-exposure contour, d >= 0. On the displayed image the shutter blends
/// to frame_level, the display value of the shadowed frame (post-processed frames show it near
/// black, not at 0: scatter and leakage reach it).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

#include "gimm/core/error.hpp"
#include "gimm/core/image.hpp"

namespace gimm {

enum class ShutterShape { none, rectangular, octagonal, circular };

inline ShutterShape parse_shutter_shape(const std::string& s) {
  if (s == "none") return ShutterShape::none;
  if (s == "rectangular") return ShutterShape::rectangular;
  if (s == "octagonal") return ShutterShape::octagonal;
  if (s == "circular") return ShutterShape::circular;
  GIMM_FAIL("shutter shape must be none|rectangular|octagonal|circular, got '" << s << "'");
}

inline const char* to_string(ShutterShape s) {
  switch (s) {
    case ShutterShape::none:
      return "none";
    case ShutterShape::rectangular:
      return "rectangular";
    case ShutterShape::octagonal:
      return "octagonal";
    case ShutterShape::circular:
      return "circular";
  }
  return "?";
}

/// Defaults: a rectangular field leaving a thin frame on every side, as most cine runs show.
struct Shutter {
  ShutterShape shape = ShutterShape::rectangular;
  double half_width = 0.92;   ///< rectangle/octagon: half width / (cols / 2), [0.2, 1.5]
  double half_height = 0.92;  ///< rectangle/octagon: half height / (rows / 2), [0.2, 1.5]
  double corner_cut = 0.35;   ///< octagon: corner cut / min(half sizes), [0, 1]
  double radius = 1.0;        ///< circle: radius / (min(rows, cols) / 2), [0.2, 1.5]
  double center_u = 0.0;      ///< field centre offset / cols, [-0.25, 0.25]
  double center_v = 0.0;      ///< field centre offset / rows, [-0.25, 0.25]
  double penumbra_px = 6.0;   ///< 10%-90% edge width, px, [0, 64]; 0 = a hard edge
  double frame_level = 0.05;  ///< display value of the shadowed frame, [0, 0.5]

  void validate() const {
    const auto in = [](const char* name, double v, double lo, double hi, const char* unit) {
      GIMM_CHECK(std::isfinite(v) && v >= lo && v <= hi, "shutter: " << name << " must be in ["
                                                                     << lo << ", " << hi << "]"
                                                                     << unit << ", got " << v);
    };
    in("half_width", half_width, 0.2, 1.5, "");
    in("half_height", half_height, 0.2, 1.5, "");
    in("corner_cut", corner_cut, 0.0, 1.0, "");
    in("radius", radius, 0.2, 1.5, "");
    in("center_u", center_u, -0.25, 0.25, "");
    in("center_v", center_v, -0.25, 0.25, "");
    in("penumbra_px", penumbra_px, 0.0, 64.0, " px");
    in("frame_level", frame_level, 0.0, 0.5, "");
  }

  /// Signed distance (px) of pixel (row, col) of a rows x cols image from the field edge,
  /// positive inside. Exact for the circle and inside the rectangle; the octagon's cut corners
  /// and the rectangle's outside corners are within a factor sqrt(2) of the Euclidean
  /// distance, which only reshapes the penumbra at a corner. +inf with no shutter.
  double signed_distance(int rows, int cols, double row, double col) const {
    if (shape == ShutterShape::none) return std::numeric_limits<double>::infinity();
    const double x = col - ((cols - 1) / 2.0 + center_u * cols);
    const double y = row - ((rows - 1) / 2.0 + center_v * rows);
    if (shape == ShutterShape::circular)
      return radius * std::min(rows, cols) / 2.0 - std::hypot(x, y);
    const double hx = half_width * cols / 2.0, hy = half_height * rows / 2.0;
    const double qx = std::abs(x) - hx, qy = std::abs(y) - hy;  // > 0: outside that blade pair
    const double box =
        qx > 0 || qy > 0 ? -std::hypot(std::max(qx, 0.0), std::max(qy, 0.0)) : -std::max(qx, qy);
    if (shape == ShutterShape::rectangular) return box;
    const double cut = corner_cut * std::min(hx, hy);
    const double diagonal = (hx + hy - cut - std::abs(x) - std::abs(y)) / std::sqrt(2.0);
    return std::min(box, diagonal);
  }

  /// Exposed fraction of pixel (row, col), in [0, 1]: the penumbra profile above.
  double exposure(int rows, int cols, double row, double col) const {
    const double d = signed_distance(rows, cols, row, col);
    if (penumbra_px == 0 || !std::isfinite(d)) return d >= 0 ? 1.0 : 0.0;
    const double s = penumbra_px / 2.563;  // 10%-90% of a Gaussian edge = 2.563 sigma
    return 0.5 * std::erfc(-d / (s * std::sqrt(2.0)));
  }
};

/// Exposed fraction of every pixel of a rows x cols image, [0, 1].
inline Image<float> shutter_exposure(const Shutter& shutter, int rows, int cols) {
  shutter.validate();
  Image<float> out(rows, cols, 1.0f);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c)
      out(r, c) = static_cast<float>(shutter.exposure(rows, cols, r, c));
  return out;
}

/// The exposed field as a mask: 1 where at least half the beam arrives (d >= 0), else 0.
inline Image<std::uint8_t> shutter_field_mask(const Shutter& shutter, int rows, int cols) {
  shutter.validate();
  Image<std::uint8_t> out(rows, cols, 1);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) out(r, c) = shutter.signed_distance(rows, cols, r, c) >= 0;
  return out;
}

/// The shutter on a displayed image in [0, 1]: value e v + (1 - e) frame_level, e the exposure.
inline void apply_shutter(Image<float>& display, const Shutter& shutter) {
  shutter.validate();
  if (shutter.shape == ShutterShape::none) return;
  for (int r = 0; r < display.rows(); ++r)
    for (int c = 0; c < display.cols(); ++c) {
      const double e = shutter.exposure(display.rows(), display.cols(), r, c);
      display(r, c) = static_cast<float>(e * display(r, c) + (1 - e) * shutter.frame_level);
    }
}

}  // namespace gimm
