#pragma once
/// The DRR renderer: one ray per detector pixel (through the pixel centre), line integrals of
/// an attenuation volume (mm^-1) -> dimensionless optical depth, and Beer-Lambert intensity.
///
/// Multithreaded over detector rows (OpenMP, dynamic schedule); every pixel is computed on its
/// own from the camera and the volume, so the image is bit-identical on any thread count.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>

#include "gimm/core/error.hpp"
#include "gimm/core/image.hpp"
#include "gimm/core/parallel.hpp"
#include "gimm/core/volume.hpp"
#include "gimm/geometry/camera.hpp"
#include "gimm/render/axial_pad.hpp"
#include "gimm/render/empty_space.hpp"
#include "gimm/render/ray_volume.hpp"
#include "gimm/render/siddon.hpp"
#include "gimm/render/trilinear.hpp"

namespace gimm {

enum class Projector { siddon, trilinear };

inline Projector parse_projector(const std::string& name) {
  if (name == "siddon") return Projector::siddon;
  if (name == "trilinear") return Projector::trilinear;
  GIMM_FAIL("projector must be siddon|trilinear, got '" << name << "'");
}

inline const char* to_string(Projector p) {
  return p == Projector::siddon ? "siddon" : "trilinear";
}

struct DrrOptions {
  Projector projector = Projector::siddon;
  double step_mm = 0.0;          ///< trilinear step; 0 = the smallest voxel spacing
  bool skip_empty_space = true;  ///< jump over blocks of zeros (empty_space.hpp); same result
  /// The empty-block grid of the volume, when one is rendered many times (else built per call).
  const EmptyBlocks* empty_blocks = nullptr;
};

namespace detail {
/// Below this fraction of empty blocks the exact projector walks whole rays with its two-ray
/// interleave (siddon_integral_pair), which skipping gives up. Measured on 256^3 volumes:
/// skipping 8% slower at 36% empty, 2% faster at 41% (break-even near 40%); a vessel box at 93%
/// empty projects 2.5x faster (docs/performance.md). 50% keeps a margin over the break-even.
inline constexpr double kSiddonSkipMinEmpty = 0.5;

/// The exact integral of one ray over the occupied blocks only (for_each_occupied_interval).
template <class T>
double siddon_integral_skipping(const Volume<T>& mu, const EmptyBlocks& empty,
                                const IndexRay& ray) {
  double s_enter, s_exit;
  const glm::dvec3 half(0.5);
  const IndexRay shifted{ray.origin + half, ray.direction};  // clip_to_box on [0, n], as Siddon
  if (!clip_to_box(shifted, glm::dvec3(0.0), glm::dvec3(mu.nx(), mu.ny(), mu.nz()), 0.0, s_enter,
                   s_exit))
    return 0.0;
  double sum = 0.0;
  for_each_occupied_interval(empty, ray, s_enter, s_exit, [&](double s0, double s1) {
    sum += siddon_integral(mu, ray, s0, s1);
  });
  return sum;
}
}  // namespace detail

/// Line integrals (optical depth, unitless when `mu` is in mm^-1) over the detector of `camera`.
template <class T>
Image<float> render_line_integrals(const Volume<T>& mu, const Camerad& camera,
                                   const DrrOptions& options = {}) {
  const double step = options.step_mm > 0 ? options.step_mm : mu.spacing().minCoeff();
  GIMM_CHECK(std::isfinite(step), "render: step must be finite, got " << options.step_mm);
  // More than 100 samples per voxel add nothing to a trilinear interpolant (1e-9 mm hung).
  GIMM_CHECK(step >= mu.spacing().minCoeff() / 100,
             "render: step " << step << " mm is below 1/100 of the smallest voxel spacing ("
                             << mu.spacing().minCoeff() << " mm)");
  GIMM_CHECK(!options.empty_blocks || options.empty_blocks->fits(mu.nx(), mu.ny(), mu.nz()),
             "render: the empty-block grid was built for another volume than "
                 << mu.nx() << "x" << mu.ny() << "x" << mu.nz());
  Image<float> out(camera.rows(), camera.cols(), 0.0f);
  const RayGenerator rays(camera);
  const IndexSpace to_index(mu.geometry());
  const int cols = camera.cols();
  // Blocks of zeros are skipped exactly by both projectors (empty_space.hpp).
  const EmptyBlocks built = options.skip_empty_space && !options.empty_blocks && mu.size() > 0
                                ? EmptyBlocks(mu)
                                : EmptyBlocks();
  const EmptyBlocks& empty = options.empty_blocks ? *options.empty_blocks : built;
  const bool skip = options.skip_empty_space && empty.built();
  const bool siddon = options.projector == Projector::siddon;
  const bool siddon_skip = siddon && skip && empty.empty_fraction() >= detail::kSiddonSkipMinEmpty;
  parallel_for_dynamic(0, camera.rows(), 4, [&](std::int64_t row) {
    float* line = out.data() + row * cols;
    const double v = static_cast<double>(row);
    int col = 0;
    if (siddon && !siddon_skip) {
      for (; col + 1 < cols; col += 2) {  // two rays interleaved (siddon_integral_pair)
        double a = 0, b = 0;
        siddon_integral_pair(mu, to_index(rays(col, v)), to_index(rays(col + 1, v)), a, b);
        line[col] = static_cast<float>(a);
        line[col + 1] = static_cast<float>(b);
      }
    }
    for (; col < cols; ++col) {
      const IndexRay ray = to_index(rays(col, v));
      double sum;
      if (siddon)
        sum = siddon_skip ? detail::siddon_integral_skipping(mu, empty, ray)
                          : siddon_integral(mu, ray);
      else
        sum = trilinear_integral(mu, ray, step, 0.0, skip ? &empty : nullptr);
      line[col] = static_cast<float>(sum);
    }
  });
  return out;
}

/// Line integrals through `mu` and its axial pads (axial_pad.hpp: the patient beyond the scan),
/// which adjoin it without overlap, so the sums are the integrals through the padded volume.
/// Exact projector only (a thick slab is not the trilinear field of thin copies: pad_axial the
/// volume instead, as padded_attenuation.hpp does). `options.empty_blocks`, if given, belongs to
/// `mu`; the pads build their own.
template <class T>
Image<float> render_line_integrals(const Volume<T>& mu, const AxialPads<T>& pads,
                                   const Camerad& camera, const DrrOptions& options = {}) {
  GIMM_CHECK(pads.empty() || options.projector == Projector::siddon,
             "axial pads are integrated exactly by the siddon projector only, not by "
                 << to_string(options.projector) << " (pad the volume itself with pad_axial)");
  Image<float> out = render_line_integrals(mu, camera, options);
  if (pads.empty()) return out;
  DrrOptions pad_options = options;
  pad_options.empty_blocks = nullptr;
  for (const Volume<T>* pad : {&pads.below, &pads.above}) {
    const Image<float> more = render_line_integrals(*pad, camera, pad_options);
    for (std::size_t p = 0; p < out.size(); ++p) out.data()[p] += more.data()[p];
  }
  return out;
}

/// A binary mask (nonzero = vessel) as 0/1 floats: the chord weights project_mask integrates.
template <class T>
Volume<float> unit_mask(const Volume<T>& mask) {
  Volume<float> unit(mask.geometry(), 0.0f);
  for (std::size_t n = 0; n < mask.size(); ++n) unit.data()[n] = mask.data()[n] != T(0);
  return unit;
}

/// The 2D vessel mask of a unit mask (unit_mask): pixels whose ray crosses at least
/// `min_chord_mm` of vessel voxels (exact Siddon chord through the voxel model). Vessels fill a
/// few % of their box, so the empty blocks are skipped; pass `empty` (EmptyBlocks(unit)) when
/// projecting one mask many times.
inline Image<std::uint8_t> project_unit_mask(const Volume<float>& unit, const Camerad& camera,
                                             double min_chord_mm = 1e-6,
                                             const EmptyBlocks* empty = nullptr) {
  DrrOptions options;
  options.empty_blocks = empty;
  const Image<float> chord = render_line_integrals(unit, camera, options);
  Image<std::uint8_t> out(camera.rows(), camera.cols(), 0);
  for (std::size_t p = 0; p < out.size(); ++p) out.data()[p] = chord.data()[p] >= min_chord_mm;
  return out;
}

/// The same from any binary 3D mask (nonzero = vessel).
template <class T>
Image<std::uint8_t> project_mask(const Volume<T>& mask, const Camerad& camera,
                                 double min_chord_mm = 1e-6) {
  return project_unit_mask(unit_mask(mask), camera, min_chord_mm);
}

/// The values a 16-bit image's 0 and 65535 stand for: value v means lo + (hi - lo) v / 65535.
struct IntensityWindow {
  double lo = 0, hi = 0;
};

/// Min-max normalisation to the full 16-bit range (a constant image becomes 0), for PNG output;
/// the window used goes to `window` when given, so that intensities can be recovered.
inline Image<std::uint16_t> to_uint16_min_max(const Image<float>& image,
                                              IntensityWindow* window = nullptr) {
  Image<std::uint16_t> out(image.rows(), image.cols(), 0);
  if (image.empty()) return out;
  const auto [lo_it, hi_it] = std::minmax_element(image.storage().begin(), image.storage().end());
  const double lo = *lo_it, hi = *hi_it;
  if (window) *window = {lo, hi};
  const double scale = hi > lo ? 65535.0 / (hi - lo) : 0.0;
  for (std::size_t p = 0; p < out.size(); ++p)
    out.data()[p] = static_cast<std::uint16_t>(std::lround((image.data()[p] - lo) * scale));
  return out;
}

/// Beer-Lambert: I = I0 exp(-line integral), per pixel.
inline Image<float> beer_lambert(const Image<float>& line_integrals, double i0 = 1.0) {
  Image<float> out(line_integrals.rows(), line_integrals.cols());
  for (std::size_t p = 0; p < out.size(); ++p)
    out.data()[p] =
        static_cast<float>(i0 * std::exp(-static_cast<double>(line_integrals.data()[p])));
  return out;
}

}  // namespace gimm
