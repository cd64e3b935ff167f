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
  bool skip_empty_space = true;  ///< trilinear: jump over blocks of zeros (empty_space.hpp)
};

/// Line integrals (optical depth, unitless when `mu` is in mm^-1) over the detector of `camera`.
template <class T>
Image<float> render_line_integrals(const Volume<T>& mu, const Camerad& camera,
                                   const DrrOptions& options = {}) {
  const double step = options.step_mm > 0 ? options.step_mm : mu.spacing().minCoeff();
  GIMM_CHECK(std::isfinite(step), "render: step must be finite, got " << options.step_mm);
  Image<float> out(camera.rows(), camera.cols(), 0.0f);
  const RayGenerator rays(camera);
  const IndexSpace to_index(mu.geometry());
  const int cols = camera.cols();
  // Air blocks are skipped by the ray marcher (exactly; empty_space.hpp).
  const bool skip = options.projector == Projector::trilinear && options.skip_empty_space;
  const EmptyBlocks empty = skip ? EmptyBlocks(mu) : EmptyBlocks();
  parallel_for_dynamic(0, camera.rows(), 4, [&](std::int64_t row) {
    float* line = out.data() + row * cols;
    const double v = static_cast<double>(row);
    int col = 0;
    if (options.projector == Projector::siddon) {
      for (; col + 1 < cols; col += 2) {  // two rays interleaved (siddon_integral_pair)
        double a = 0, b = 0;
        siddon_integral_pair(mu, to_index(rays(col, v)), to_index(rays(col + 1, v)), a, b);
        line[col] = static_cast<float>(a);
        line[col + 1] = static_cast<float>(b);
      }
    }
    for (; col < cols; ++col) {
      const IndexRay ray = to_index(rays(col, v));
      line[col] = static_cast<float>(options.projector == Projector::siddon
                                         ? siddon_integral(mu, ray)
                                         : trilinear_integral(mu, ray, step, 0.0, &empty));
    }
  });
  return out;
}

/// The 2D vessel mask of a binary 3D mask (nonzero = vessel): pixels whose ray crosses at
/// least `min_chord_mm` of mask voxels (exact Siddon chord through the voxel model).
template <class T>
Image<std::uint8_t> project_mask(const Volume<T>& mask, const Camerad& camera,
                                 double min_chord_mm = 1e-6) {
  Volume<float> unit(mask.geometry(), 0.0f);
  for (std::size_t n = 0; n < mask.size(); ++n) unit.data()[n] = mask.data()[n] != T(0);
  const Image<float> chord = render_line_integrals(unit, camera);
  Image<std::uint8_t> out(camera.rows(), camera.cols(), 0);
  for (std::size_t p = 0; p < out.size(); ++p) out.data()[p] = chord.data()[p] >= min_chord_mm;
  return out;
}

/// Min-max normalisation to the full 16-bit range (a constant image becomes 0), for PNG output.
inline Image<std::uint16_t> to_uint16_min_max(const Image<float>& image) {
  Image<std::uint16_t> out(image.rows(), image.cols(), 0);
  if (image.empty()) return out;
  const auto [lo_it, hi_it] = std::minmax_element(image.storage().begin(), image.storage().end());
  const double lo = *lo_it, hi = *hi_it;
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
