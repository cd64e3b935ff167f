#pragma once
/// Ray marching through the trilinearly interpolated volume with a fixed step (mm).
///
/// The field is the trilinear interpolant of the voxel values at voxel centres, with zero
/// outside the grid (volume.hpp, Volume::sample_index), so it is non-zero on the index box
/// (-1, n)^3. The integral uses the midpoint rule: the clipped interval [s0, s1] is cut into
/// floor((s1 - s0) / step) full steps and one remainder, each sampled at its midpoint and
/// weighted by its length; it converges as O(step^2) on smooth fields.
/// trilinear_integral is the fast path (no bounds checks in the interior);
/// with an EmptyBlocks grid it also jumps over blocks of air (same result up to rounding);
/// trilinear_integral_reference samples with Volume::sample_index (the slow path).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <type_traits>

#if defined(__AVX2__) && defined(__FMA__)
#include <immintrin.h>
#endif

#include "gimm/core/error.hpp"
#include "gimm/core/volume.hpp"
#include "gimm/render/empty_space.hpp"
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

/// Interior samples k0 .. k0 + n - 1 (at s_k = s0 + (k + 0.5) step; all 8 neighbours of each
/// exist, 0 <= x < nx - 1, ...), one at a time, without bounds checks: the portable path.
template <class T>
void interior_samples_scalar(const Volume<T>& volume, const IndexRay& ray, double s0, double step,
                             std::int64_t k0, std::int64_t n, double* out) {
  const T* data = volume.data();
  const std::int64_t sy = volume.nx(), sz = sy * volume.ny();
  for (std::int64_t q = 0; q < n; ++q) {
    const double s = s0 + (double(k0 + q) + 0.5) * step;
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
    out[q] = c0 + dz * (c1 - c0);
  }
}

#if defined(__AVX2__) && defined(__FMA__)
inline constexpr bool kHaveAvx2 = true;
/// The same for float volumes with AVX2, four samples per step, in double like the scalar path.
/// The two x-neighbours (i, i + 1) are adjacent floats, so each corner pair of four samples is
/// one 64-bit gather: 4 gathers per 4 samples instead of 32 scalar loads. Voxel offsets are
/// 32-bit (the caller checks the volume's size).
inline void interior_samples_avx2(const Volume<float>& volume, const IndexRay& ray, double s0,
                                  double step, std::int64_t k0, std::int64_t n, double* out) {
  const auto* base = reinterpret_cast<const double*>(volume.data());
  const int sy = volume.nx(), sz = volume.nx() * volume.ny();
  const __m256d half_steps = _mm256_setr_pd(0.5, 1.5, 2.5, 3.5);
  const __m256d ox = _mm256_set1_pd(ray.origin.x), oy = _mm256_set1_pd(ray.origin.y),
                oz = _mm256_set1_pd(ray.origin.z);
  const __m256d dx = _mm256_set1_pd(ray.direction.x), dy = _mm256_set1_pd(ray.direction.y),
                dz = _mm256_set1_pd(ray.direction.z);
  const __m128i vsy = _mm_set1_epi32(sy), vsz = _mm_set1_epi32(sz);
  const __m256i split = _mm256_setr_epi32(0, 2, 4, 6, 1, 3, 5, 7);  // (v_i, v_i+1) pairs apart
  // Interpolates along x between the pairs at offset: (a, b) -> a + fx (b - a).
  auto lerp_pairs = [&](__m128i offset, __m256d fx) {
    const __m256 pairs =
        _mm256_castpd_ps(_mm256_i32gather_pd(base, offset, 4));  // byte offset = 4 x index
    const __m256 apart = _mm256_permutevar8x32_ps(pairs, split);
    const __m256d a = _mm256_cvtps_pd(_mm256_castps256_ps128(apart));
    const __m256d b = _mm256_cvtps_pd(_mm256_extractf128_ps(apart, 1));
    return _mm256_fmadd_pd(fx, _mm256_sub_pd(b, a), a);
  };
  std::int64_t q = 0;
  for (; q + 4 <= n; q += 4) {
    const __m256d s = _mm256_fmadd_pd(_mm256_add_pd(half_steps, _mm256_set1_pd(double(k0 + q))),
                                      _mm256_set1_pd(step), _mm256_set1_pd(s0));
    const __m256d x = _mm256_fmadd_pd(s, dx, ox), y = _mm256_fmadd_pd(s, dy, oy),
                  z = _mm256_fmadd_pd(s, dz, oz);
    const __m128i i = _mm256_cvttpd_epi32(x), j = _mm256_cvttpd_epi32(y),
                  k = _mm256_cvttpd_epi32(z);
    const __m256d fx = _mm256_sub_pd(x, _mm256_cvtepi32_pd(i));
    const __m256d fy = _mm256_sub_pd(y, _mm256_cvtepi32_pd(j));
    const __m256d fz = _mm256_sub_pd(z, _mm256_cvtepi32_pd(k));
    const __m128i at =
        _mm_add_epi32(i, _mm_add_epi32(_mm_mullo_epi32(j, vsy), _mm_mullo_epi32(k, vsz)));
    const __m256d c00 = lerp_pairs(at, fx);
    const __m256d c10 = lerp_pairs(_mm_add_epi32(at, vsy), fx);
    const __m256d c01 = lerp_pairs(_mm_add_epi32(at, vsz), fx);
    const __m256d c11 = lerp_pairs(_mm_add_epi32(at, _mm_add_epi32(vsy, vsz)), fx);
    const __m256d c0 = _mm256_fmadd_pd(fy, _mm256_sub_pd(c10, c00), c00);
    const __m256d c1 = _mm256_fmadd_pd(fy, _mm256_sub_pd(c11, c01), c01);
    _mm256_storeu_pd(out + q, _mm256_fmadd_pd(fz, _mm256_sub_pd(c1, c0), c0));
  }
  interior_samples_scalar(volume, ray, s0, step, k0 + q, n - q, out + q);
}
#else
inline constexpr bool kHaveAvx2 = false;
#endif

/// Dispatch: AVX2 for float volumes whose voxel offsets fit in 32 bits, else the scalar path.
template <class T>
void interior_samples(const Volume<T>& volume, const IndexRay& ray, double s0, double step,
                      std::int64_t k0, std::int64_t n, double* out) {
#if defined(__AVX2__) && defined(__FMA__)
  if constexpr (std::is_same_v<T, float>) {
    if (volume.size() < (std::size_t(1) << 31)) {
      interior_samples_avx2(volume, ray, s0, step, k0, n, out);
      return;
    }
  }
#endif
  interior_samples_scalar(volume, ray, s0, step, k0, n, out);
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

/// `empty` (optional, built from the same volume) lets the walk jump over empty blocks.
template <class T>
double trilinear_integral(const Volume<T>& volume, const IndexRay& ray, double step_mm,
                          double s_min = 0.0, const EmptyBlocks* empty = nullptr) {
  GIMM_CHECK(std::isfinite(step_mm) && step_mm > 0,
             "trilinear_integral: step must be > 0 mm, got " << step_mm);
  GIMM_CHECK(
      empty == nullptr || !empty->built() || empty->fits(volume.nx(), volume.ny(), volume.nz()),
      "trilinear_integral: the empty-block grid was built for another volume than "
          << volume.nx() << "x" << volume.ny() << "x" << volume.nz());
  double s0, s1;
  const int nx = volume.nx(), ny = volume.ny(), nz = volume.nz();
  if (!clip_to_box(ray, glm::dvec3(-1.0), glm::dvec3(nx, ny, nz), s_min, s0, s1)) return 0.0;
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
  // Interior samples [k0, k1) in chunks: sampled in SIMD lanes, summed in sequential order.
  auto add_interior = [&](std::int64_t k0, std::int64_t k1) {
    constexpr std::int64_t kChunk = 64;
    double values[kChunk];
    for (std::int64_t k = k0; k < k1; k += kChunk) {
      const std::int64_t n = std::min(kChunk, k1 - k);
      detail::interior_samples(volume, ray, s0, step_mm, k, n, values);
      for (std::int64_t q = 0; q < n; ++q) sum += step_mm * values[q];
    }
  };
  if (empty == nullptr || !empty->built()) {
    add_interior(k_lo, k_hi);
  } else {
    // Samples in empty blocks are exactly 0 and are not taken; the others are summed in the
    // same order, so the sum is unchanged (up to the rounding of the vectorised loop).
    for_each_occupied_run(*empty, ray, s0, step_mm, k_lo, k_hi, add_interior);
  }
  for (std::int64_t k = k_hi; k < full; ++k)
    sum += step_mm * boundary(s0 + (double(k) + 0.5) * step_mm);
  const double rest = length - static_cast<double>(full) * step_mm;
  if (rest > 0) sum += rest * boundary(s1 - 0.5 * rest);
  return sum;
}

}  // namespace gimm
