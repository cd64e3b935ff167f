#pragma once
/// The exposed field of an angiogram: where the collimator let X-rays through.
///
/// Real frames have a dark collimator frame (rectangular, octagonal or circular shutters, with a
/// penumbra of 5-20 px and often an image-intensifier vignette). Its edge is the strongest
/// "dark line beside bright" in the image, so a vessel filter finds it and a matcher matches
/// it (21% of the geometric matcher's matches on real GE frames sat on it). The field comes
/// from the DICOM shutter tags when a file has them (io/dicom.hpp); otherwise it is found here.
///
/// Finding it: shutters are convex, so the field is an intersection of half-planes. For each of
/// `directions` outward normals n (evenly spaced; 16 keep a circle within 2% of its radius),
/// the profile p(d) is the median intensity of the pixels at depth d from the image's support
/// line along n (the middle half of each band's chord across the image, so the neighbouring
/// sides do not mix in). A collimated side is dark at d = 0 and rises to the field's level p_in
/// (the brightest point of p, over 3 bands): it counts as collimated when p_in - p(0) >=
/// `min_step` and >= `min_relative_step` p_in, and its steepest rise is a step (>= `min_slope`
/// per px; anatomy's gradients are gentler). The edge is where that rise slows to `edge_slope`
/// of its peak (the penumbra's end: a soft vignette beyond it is kept), and the field ends
/// `margin_px` further in (the vessel filter's reach). A side with no such step is not cut.
/// Searched: from the support to (1/2 - `max_depth_fraction`) of the shorter image side from
/// the centre (deeper towards the corners), on a copy reduced to about 256 px.
/// Intensities: [0, 1], vessels and collimator dark (gimm's convention).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "gimm/core/constants.hpp"
#include "gimm/core/error.hpp"
#include "gimm/core/image.hpp"
#include "gimm/match/matches.hpp"

namespace gimm {

struct FieldOfViewOptions {
  int directions = 16;               ///< half-plane normals, >= 4 and a multiple of 4
  double max_depth_fraction = 0.15;  ///< deepest edge searched, share of the shorter side
  /// The border-to-field rise that counts as a collimator: at least min_step (intensity, [0, 1])
  /// and min_relative_step of the field's level. Real frames: 0.17-0.5 and 0.35-0.8 (four
  /// clinical views); anatomy at a border without collimation (a darker heart or spine edge)
  /// rises less.
  double min_step = 0.08;
  double min_relative_step = 0.25;
  double min_slope = 0.004;  ///< the steepest part of a frame's edge rises this much per px
  double edge_slope = 0.25;  ///< the edge ends where the rise slows to this share of its peak
  double margin_px = 6;      ///< further in from the edge, px
  void validate() const {
    GIMM_CHECK(directions >= 4 && directions <= 360 && directions % 4 == 0,
               "field of view: directions must be a multiple of 4 in [4, 360], got " << directions);
    GIMM_CHECK(max_depth_fraction > 0 && max_depth_fraction <= 0.5,
               "field of view: max_depth_fraction must be in (0, 0.5], got " << max_depth_fraction);
    GIMM_CHECK(min_step > 0 && min_step < 1,
               "field of view: min_step must be in (0, 1), got " << min_step);
    GIMM_CHECK(min_relative_step >= 0 && min_relative_step < 1,
               "field of view: min_relative_step must be in [0, 1), got " << min_relative_step);
    GIMM_CHECK(min_slope > 0 && min_slope < 1,
               "field of view: min_slope must be in (0, 1), got " << min_slope);
    GIMM_CHECK(edge_slope > 0 && edge_slope < 1,
               "field of view: edge_slope must be in (0, 1), got " << edge_slope);
    GIMM_CHECK(std::isfinite(margin_px) && margin_px >= 0 && margin_px <= 256,
               "field of view: margin_px must be in [0, 256], got " << margin_px);
  }
};

/// One side of the field: pixels p with n . (p - centre) <= limit are inside.
struct FieldSide {
  double angle_rad = 0;  ///< of the outward normal n = (cos, sin) in (u, v) image axes
  double limit = 0;      ///< px from the image centre along n
  bool collimated = false;
};

namespace detail {

/// `image` reduced `f` times: each pixel the mean of an f x f block (a partial last block is
/// dropped; the centres stay aligned when the size is a multiple of f).
inline Image<float> block_mean(const Image<float>& image, int f) {
  Image<float> out(image.rows() / f, image.cols() / f, 0.0f);
  for (int r = 0; r < out.rows() * f; ++r)
    for (int c = 0; c < out.cols() * f; ++c) out(r / f, c / f) += image(r, c);
  for (float& v : out.storage()) v /= float(f * f);
  return out;
}

inline double median_of(std::vector<float>& values) {
  if (values.empty()) return std::nan("");
  const auto mid = values.begin() + std::ptrdiff_t(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

/// The side of the field whose outward normal is at `angle` (see the header comment).
/// `image` is the frame reduced `scale` times (block means); the side comes back in the frame's
/// own pixels, slopes are per frame pixel.
inline FieldSide field_side(const Image<float>& image, double angle, const FieldOfViewOptions& o,
                            int scale) {
  const double nu = std::cos(angle), nv = std::sin(angle);
  const double cu = (image.cols() - 1) / 2.0, cv = (image.rows() - 1) / 2.0;
  // The support: the farthest pixel centre along n (a corner). The profile runs in from it until
  // its band passes (1/2 - max_depth_fraction) of the shorter side from the centre: for the
  // four axis directions that is max_depth_fraction of the side, towards a corner further, so
  // that a cut corner (an octagon, a circle) is searched as deep as a side.
  const double support = std::abs(nu) * cu + std::abs(nv) * cv;
  const double nearest = (0.5 - o.max_depth_fraction) * std::min(image.rows(), image.cols());
  const int depth = std::max(4, int(support - nearest));
  std::vector<std::vector<std::pair<float, float>>> bands(std::size_t(depth) + 1);
  for (int r = 0; r < image.rows(); ++r)
    for (int c = 0; c < image.cols(); ++c) {
      const double du = c - cu, dv = r - cv;
      const double d = support - (nu * du + nv * dv);
      if (d >= depth + 1) continue;
      bands[std::size_t(d)].push_back({float(-nv * du + nu * dv), image(r, c)});
    }
  std::vector<double> profile(bands.size());
  for (std::size_t d = 0; d < bands.size(); ++d) {
    auto& band = bands[d];
    float lo = std::numeric_limits<float>::max(), hi = -lo;
    for (const auto& [s, v] : band) {
      lo = std::min(lo, s);
      hi = std::max(hi, s);
    }
    std::vector<float> central;  // the middle half of the band's chord across the image
    for (const auto& [s, v] : band)
      if (std::abs(s - (lo + hi) / 2) <= (hi - lo) / 4 + 0.5f) central.push_back(v);
    profile[d] = median_of(central);
  }
  // The field's level beside this side: the brightest point of the profile (averaged over 3
  // bands). Not the centre's: anatomy near a side may be darker or brighter than the middle of
  // the image, and towards the corners of a round or octagonal field no fixed depth is sure to
  // be clear of the frame.
  const auto smooth = [&](std::size_t d) {
    const std::size_t a = d == 0 ? 0 : d - 1, b = std::min(profile.size() - 1, d + 1);
    return (profile[a] + profile[d] + profile[b]) / 3;
  };
  double inside = -1;
  for (std::size_t d = 0; d < profile.size(); ++d) inside = std::max(inside, smooth(d));
  const double rise = inside - profile[0];
  // A pixel centre at the support is inside.
  FieldSide side{angle, scale * (support + 0.5), false};
  if (!(rise >= o.min_step && rise >= o.min_relative_step * inside)) return side;
  // The frame's edge is a step, anatomy's gradients are gentle: find the steepest rise (slope
  // over 4 bands) and follow it in until the slope falls below `edge_slope` of its peak.
  const auto slope = [&](std::size_t d) {
    const std::size_t a = d < 2 ? 0 : d - 2, b = std::min(profile.size() - 1, d + 2);
    return (smooth(b) - smooth(a)) / double(b - a) / scale;
  };
  std::size_t steepest = 0;
  for (std::size_t d = 0; d < profile.size(); ++d)
    if (slope(d) > slope(steepest)) steepest = d;
  if (!(slope(steepest) >= o.min_slope)) return side;
  std::size_t edge = steepest;
  while (edge + 1 < profile.size() && slope(edge) >= o.edge_slope * slope(steepest)) ++edge;
  side.collimated = true;
  side.limit = scale * (support - double(edge)) - o.margin_px;
  return side;
}

}  // namespace detail

/// The field's sides, one per direction (FieldOfViewOptions), found in `image`.
inline std::vector<FieldSide> exposed_field_sides(const Image<float>& image,
                                                  const FieldOfViewOptions& options = {}) {
  options.validate();
  GIMM_CHECK(image.rows() >= 16 && image.cols() >= 16, "field of view: the image is "
                                                           << image.cols() << " x " << image.rows()
                                                           << " px; at least 16 x 16 needed");
  // Edges are found on a copy reduced to about 256 px (block means): 4x fewer pixels at 512 px,
  // the edge within a pixel of the reduced copy, inside the margin.
  const int scale = std::max(1, std::min(image.rows(), image.cols()) / 256);
  const Image<float> reduced = scale == 1 ? image : detail::block_mean(image, scale);
  std::vector<FieldSide> sides;
  for (int k = 0; k < options.directions; ++k)
    sides.push_back(detail::field_side(reduced, 2 * kPi * k / options.directions, options, scale));
  return sides;
}

/// The mask of pixels inside every side: 1 exposed, 0 collimated.
inline Image<std::uint8_t> field_mask(const std::vector<FieldSide>& sides, int rows, int cols) {
  Image<std::uint8_t> mask(rows, cols, 1);
  const double cu = (cols - 1) / 2.0, cv = (rows - 1) / 2.0;
  for (const FieldSide& side : sides) {
    if (!side.collimated) continue;
    const double nu = std::cos(side.angle_rad), nv = std::sin(side.angle_rad);
    for (int r = 0; r < rows; ++r)
      for (int c = 0; c < cols; ++c)
        if (nu * (c - cu) + nv * (r - cv) > side.limit) mask(r, c) = 0;
  }
  return mask;
}

/// The exposed field of `image` (1 inside), found from the image alone.
inline Image<std::uint8_t> exposed_field(const Image<float>& image,
                                         const FieldOfViewOptions& options = {}) {
  return field_mask(exposed_field_sides(image, options), image.rows(), image.cols());
}

/// The share of pixels inside `field`, [0, 1].
inline double field_fraction(const Image<std::uint8_t>& field) {
  std::size_t inside = 0;
  for (std::size_t k = 0; k < field.size(); ++k) inside += field.data()[k] != 0;
  return field.size() ? double(inside) / double(field.size()) : 0.0;
}

/// `mask` with every pixel outside `field` cleared; sizes must agree.
inline void clear_outside(Image<std::uint8_t>& mask, const Image<std::uint8_t>& field) {
  GIMM_CHECK(mask.rows() == field.rows() && mask.cols() == field.cols(),
             "field of view: the field is " << field.cols() << " x " << field.rows()
                                            << ", the mask " << mask.cols() << " x "
                                            << mask.rows());
  for (std::size_t k = 0; k < mask.size(); ++k)
    if (!field.data()[k]) mask.data()[k] = 0;
}

/// Whether image point (u, v) lies on a pixel inside `field` (pixel centres at integers); a
/// null field is the whole image.
inline bool in_field(const Image<std::uint8_t>* field, const Eigen::Vector2d& p) {
  if (!field) return true;
  const long c = std::lround(p.x()), r = std::lround(p.y());
  return r >= 0 && c >= 0 && r < field->rows() && c < field->cols() && (*field)(int(r), int(c));
}

/// Drops the matches with an end outside its view's field; returns how many.
inline std::size_t drop_outside_fields(PairMatches& m, const Image<std::uint8_t>* field_a,
                                       const Image<std::uint8_t>* field_b) {
  PairMatches kept;
  kept.pair = m.pair;
  kept.F = m.F;
  kept.F_source = m.F_source;
  for (std::size_t k = 0; k < m.size(); ++k)
    if (in_field(field_a, m.points_a[k]) && in_field(field_b, m.points_b[k]))
      kept.add(m.points_a[k], m.points_b[k], m.confidence[k]);
  const std::size_t dropped = m.size() - kept.size();
  m = std::move(kept);
  return dropped;
}

}  // namespace gimm
