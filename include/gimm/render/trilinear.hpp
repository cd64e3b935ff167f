#pragma once
/// Ray marching through the trilinearly interpolated volume with a fixed step (mm).
///
/// The field is the trilinear interpolant of the voxel values at voxel centres, with zero
/// outside the grid (volume.hpp, Volume::sample_index), so it is non-zero on the index box
/// (-1, n)^3. The integral uses the midpoint rule: the clipped interval [s0, s1] is cut into
/// floor((s1 - s0) / step) full steps and one remainder, each sampled at its midpoint and
/// weighted by its length; it converges as O(step^2) on smooth fields.
/// trilinear_integral is the fast path (no bounds checks in the interior);
/// trilinear_integral_reference samples with Volume::sample_index (the slow path).
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "gimm/core/error.hpp"
#include "gimm/core/volume.hpp"
#include "gimm/render/ray_volume.hpp"

namespace gimm {

namespace detail {
/// Calls f(s, weight) for each midpoint sample of [s0, s1] at `step`.
template <class F>
void for_each_midpoint(double s0, double s1, double step, F&& f) {
  const double length = s1 - s0;
  const auto full = static_cast<std::int64_t>(std::floor(length / step));
  for (std::int64_t k = 0; k < full; ++k) f(s0 + (static_cast<double>(k) + 0.5) * step, step);
  const double rest = length - static_cast<double>(full) * step;
  if (rest > 0) f(s1 - 0.5 * rest, rest);
}
}  // namespace detail

template <class T>
double trilinear_integral_reference(const Volume<T>& volume, const IndexRay& ray, double step_mm,
                                    double s_min = 0.0) {
  GIMM_CHECK(std::isfinite(step_mm) && step_mm > 0,
             "trilinear_integral: step must be > 0 mm, got " << step_mm);
  double s0, s1;
  const glm::dvec3 hi(volume.nx(), volume.ny(), volume.nz());
  if (!clip_to_box(ray, glm::dvec3(-1.0), hi, s_min, s0, s1)) return 0.0;
  double sum = 0.0;
  detail::for_each_midpoint(s0, s1, step_mm, [&](double s, double w) {
    const glm::dvec3 p = ray.origin + s * ray.direction;
    sum += w * volume.sample_index(Eigen::Vector3d(p.x, p.y, p.z));
  });
  return sum;
}

template <class T>
double trilinear_integral(const Volume<T>& volume, const IndexRay& ray, double step_mm,
                          double s_min = 0.0) {
  GIMM_CHECK(std::isfinite(step_mm) && step_mm > 0,
             "trilinear_integral: step must be > 0 mm, got " << step_mm);
  double s0, s1;
  const int nx = volume.nx(), ny = volume.ny(), nz = volume.nz();
  if (!clip_to_box(ray, glm::dvec3(-1.0), glm::dvec3(nx, ny, nz), s_min, s0, s1)) return 0.0;
  const T* data = volume.data();
  const std::int64_t sy = nx, sz = static_cast<std::int64_t>(nx) * ny;
  // One trilinear sample where all 8 neighbours exist (0 <= x < nx - 1, ...): no checks.
  auto interior = [&](double s) {
    const double x = ray.origin.x + s * ray.direction.x;
    const double y = ray.origin.y + s * ray.direction.y;
    const double z = ray.origin.z + s * ray.direction.z;
    const int i = static_cast<int>(x), j = static_cast<int>(y), k = static_cast<int>(z);
    const double dx = x - i, dy = y - j, dz = z - k;
    const T* c = data + i + sy * j + sz * k;
    auto at = [c](std::int64_t offset) { return static_cast<double>(c[offset]); };
    const double c00 = at(0) + dx * (at(1) - at(0));
    const double c10 = at(sy) + dx * (at(sy + 1) - at(sy));
    const double c01 = at(sz) + dx * (at(sz + 1) - at(sz));
    const double c11 = at(sz + sy) + dx * (at(sz + sy + 1) - at(sz + sy));
    const double c0 = c00 + dy * (c10 - c00);
    const double c1 = c01 + dy * (c11 - c01);
    return c0 + dz * (c1 - c0);
  };
  auto boundary = [&](double s) {
    const glm::dvec3 p = ray.origin + s * ray.direction;
    return volume.sample_index(Eigen::Vector3d(p.x, p.y, p.z));
  };
  // The full steps whose midpoints lie in the interior box (shrunk by 1e-6 voxel against
  // rounding) run without a per-sample bounds test; the others take the general sampler.
  const double length = s1 - s0;
  const auto full = static_cast<std::int64_t>(std::floor(length / step_mm));
  std::int64_t k_lo = full, k_hi = full;
  double t0, t1;
  // A side of one voxel has no interior (every sample needs the general sampler).
  if (nx >= 2 && ny >= 2 && nz >= 2 &&
      clip_to_box(ray, glm::dvec3(1e-6), glm::dvec3(nx - 1 - 1e-6, ny - 1 - 1e-6, nz - 1 - 1e-6),
                  s_min, t0, t1)) {
    k_lo = std::clamp<std::int64_t>(
        static_cast<std::int64_t>(std::ceil((t0 - s0) / step_mm - 0.5)) + 1, 0, full);
    k_hi = std::clamp<std::int64_t>(
        static_cast<std::int64_t>(std::floor((t1 - s0) / step_mm - 0.5)) - 1, k_lo, full);
  }
  double sum = 0.0;
  for (std::int64_t k = 0; k < k_lo; ++k)
    sum += step_mm * boundary(s0 + (double(k) + 0.5) * step_mm);
  // Interior samples in chunks: the sampling loop vectorises (gathers), the sum keeps the
  // sequential order, so the result is the same as one sample at a time.
  constexpr std::int64_t kChunk = 64;
  double values[kChunk];
  for (std::int64_t k = k_lo; k < k_hi; k += kChunk) {
    const std::int64_t n = std::min(kChunk, k_hi - k);
#pragma omp simd
    for (std::int64_t q = 0; q < n; ++q) values[q] = interior(s0 + (double(k + q) + 0.5) * step_mm);
    for (std::int64_t q = 0; q < n; ++q) sum += step_mm * values[q];
  }
  for (std::int64_t k = k_hi; k < full; ++k)
    sum += step_mm * boundary(s0 + (double(k) + 0.5) * step_mm);
  const double rest = length - static_cast<double>(full) * step_mm;
  if (rest > 0) sum += rest * boundary(s1 - 0.5 * rest);
  return sum;
}

}  // namespace gimm
