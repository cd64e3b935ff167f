#pragma once
/// The phantom's irregular vessel course (PhantomOptions::tortuosity, anatomy/phantom.hpp draws
/// it).
#include <cmath>

#include "gimm/core/error.hpp"

namespace gimm {

/// The vessels' course without the classic tree's two regular sinusoids (issue "synthetic
/// angiograms that look like real ones": real coronaries wander irregularly, the sinusoids repeat
/// two wavelengths). Instead of them, a lateral displacement on the heart's surface of
/// sigma_mm * g(s), g a unit-variance smooth process along the path's arc length s
/// (detail::smooth_process of anatomy/lumen.hpp: white noise smoothed over correlation_mm),
/// ramped in over the first 8 mm as the sinusoids were, so every branch keeps its origin on its
/// parent. Drawn from a stream of its own; the control points and every other draw of the seed
/// stay. 0: the classic course, byte for byte.
struct TortuosityOptions {
  double sigma_mm = 0;        ///< [0, 5] mm; 0 = the classic course
  double correlation_mm = 4;  ///< (0, 50] mm along the vessel
  bool none() const { return sigma_mm == 0; }
  void validate() const {
    GIMM_CHECK(std::isfinite(sigma_mm) && sigma_mm >= 0 && sigma_mm <= 5,
               "TortuosityOptions::sigma_mm must be in [0, 5] mm, got " << sigma_mm);
    GIMM_CHECK(std::isfinite(correlation_mm) && correlation_mm > 0 && correlation_mm <= 50,
               "TortuosityOptions::correlation_mm must be in (0, 50] mm, got " << correlation_mm);
  }
};

}  // namespace gimm
