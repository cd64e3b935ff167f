#pragma once
/// Acquisition effects applied to a rendered angiogram after the fact, for stability sweeps:
/// blur (focal spot and detector) and quantum noise at a given dose.
///
/// The image is the dataset's display intensity in [0, 1] (bright background, dark vessels),
/// read as the transmitted fraction I / I0. Noise: each pixel's photon count is
/// Poisson(photons x value) and the pixel becomes count / photons, so `photons` is the count an
/// unattenuated pixel receives: lower = less dose = more noise (relative noise 1 / sqrt(count)).
/// The dataset's window is not undone, so this is a model of dose on the displayed image, not
/// of the detector signal. Blur comes first (it acts on the signal, the noise on the detector).
/// Deterministic: the noise comes from gimm::Rng, the same on every platform.
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "gimm/core/error.hpp"
#include "gimm/core/filter.hpp"
#include "gimm/core/image.hpp"
#include "gimm/core/rng.hpp"

namespace gimm {

struct ImageDegradation {
  double photons = 0;  ///< photons per unattenuated pixel (Poisson noise); 0 = no noise
  double blur_px = 0;  ///< Gaussian blur sigma, pixels; 0 = no blur
  bool none() const { return photons == 0 && blur_px == 0; }
  void validate() const {
    GIMM_CHECK(photons == 0 || (std::isfinite(photons) && photons >= 1),
               "ImageDegradation::photons must be 0 (no noise) or >= 1, got " << photons);
    GIMM_CHECK(std::isfinite(blur_px) && blur_px >= 0 && blur_px <= 16,
               "ImageDegradation::blur_px must be in [0, 16] px, got " << blur_px);
  }
};

/// A Poisson draw: Knuth's product of uniforms below a mean of 30, above it the normal
/// approximation (rounded, clamped at 0), whose error at that mean is far below the noise itself.
inline double poisson_draw(double mean, Rng& rng) {
  if (mean <= 0) return 0;
  if (mean >= 30) return std::max(0.0, std::round(mean + std::sqrt(mean) * rng.normal()));
  const double limit = std::exp(-mean);
  double product = rng.uniform(), count = 0;
  while (product > limit) {
    product *= rng.uniform();
    count += 1;
  }
  return count;
}

/// The image blurred, then with quantum noise; values stay in [0, 1].
inline Image<float> degrade_image(const Image<float>& image, const ImageDegradation& d, Rng& rng) {
  d.validate();
  Image<float> out = gaussian_blur(image, d.blur_px);
  if (d.photons > 0)
    for (float& v : out.storage()) {
      const double count = poisson_draw(d.photons * std::clamp(double(v), 0.0, 1.0), rng);
      v = static_cast<float>(std::min(1.0, count / d.photons));
    }
  return out;
}

}  // namespace gimm
