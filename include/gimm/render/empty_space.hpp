#pragma once
/// Empty-space skipping: a coarse grid of blocks that marks where a volume is zero, so that ray
/// marchers can jump over air (0 mm^-1) instead of sampling it.
///
/// Block b covers the trilinear cells with base index [b B, b B + B) on each axis; a cell with
/// base index i interpolates voxels i and i + 1, so a block is empty when every voxel in
/// [b B, b B + B] (B + 1 per axis, clipped to the grid) is exactly zero. Every sample whose
/// base cell lies in an empty block is then exactly 0, and skipping it leaves a sum unchanged
/// bit for bit (s + 0 == s). For the exact (Siddon) projector a block is the index-space box
/// [b B, (b + 1) B]^3: every point in it lies in a voxel of [b B, b B + B], all zero, so the
/// chord through it adds nothing (for_each_occupied_interval).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "gimm/core/parallel.hpp"
#include "gimm/core/volume.hpp"
#include "gimm/render/ray_volume.hpp"

namespace gimm {

class EmptyBlocks {
 public:
  static constexpr int kShift = 4;  ///< blocks of 16^3 cells
  static constexpr int kSize = 1 << kShift;

  EmptyBlocks() = default;

  template <class T>
  explicit EmptyBlocks(const Volume<T>& volume)
      : nx_(volume.nx()),
        ny_(volume.ny()),
        nz_(volume.nz()),
        bx_(blocks_along(volume.nx())),
        by_(blocks_along(volume.ny())),
        bz_(blocks_along(volume.nz())),
        empty_(static_cast<std::size_t>(bx_) * by_ * bz_, 0) {
    const int nx = volume.nx(), ny = volume.ny(), nz = volume.nz();
    const T* data = volume.data();
    const std::int64_t sy = nx, sz = static_cast<std::int64_t>(nx) * ny;
    // One task per block row; a block stops reading at its first non-zero voxel, so only the
    // empty blocks are read in full.
    parallel_for(0, static_cast<std::int64_t>(by_) * bz_, [&](std::int64_t row) {
      const int b_j = static_cast<int>(row % by_), b_k = static_cast<int>(row / by_);
      const int j0 = b_j * kSize, j1 = std::min(j0 + kSize, ny - 1);
      const int k0 = b_k * kSize, k1 = std::min(k0 + kSize, nz - 1);
      for (int b_i = 0; b_i < bx_; ++b_i) {
        const int i0 = b_i * kSize, i1 = std::min(i0 + kSize, nx - 1);
        bool zero = true;
        for (int k = k0; zero && k <= k1; ++k)
          for (int j = j0; zero && j <= j1; ++j) {
            const T* line = data + sy * j + sz * k;
            for (int i = i0; i <= i1; ++i) zero &= line[i] == T(0);
          }
        empty_[index(b_i, b_j, b_k)] = zero;
      }
    });
  }

  bool built() const { return !empty_.empty(); }
  /// Whether this grid was built for a volume of these dimensions.
  bool fits(int nx, int ny, int nz) const { return built() && nx_ == nx && ny_ == ny && nz_ == nz; }
  /// Whether the block holding base cell (i, j, k) (each in [0, n - 1)) is empty.
  bool empty_at_cell(int i, int j, int k) const {
    return empty_[index(i >> kShift, j >> kShift, k >> kShift)] != 0;
  }
  bool empty_block(int bi, int bj, int bk) const { return empty_[index(bi, bj, bk)] != 0; }
  bool contains_block(int bi, int bj, int bk) const {
    return bi >= 0 && bj >= 0 && bk >= 0 && bi < bx_ && bj < by_ && bk < bz_;
  }
  /// Blocks along axis a (0, 1, 2).
  int blocks(int a) const { return a == 0 ? bx_ : (a == 1 ? by_ : bz_); }
  /// Fraction of blocks that are empty (for reports).
  double empty_fraction() const {
    if (empty_.empty()) return 0.0;
    return static_cast<double>(std::count(empty_.begin(), empty_.end(), 1)) /
           static_cast<double>(empty_.size());
  }

 private:
  // Base cells run over [0, n - 1); a one-voxel side still gets one block.
  static int blocks_along(int n) { return std::max(1, (n - 1 + kSize - 1) / kSize); }
  std::size_t index(int i, int j, int k) const {
    return static_cast<std::size_t>(i) +
           static_cast<std::size_t>(bx_) *
               (static_cast<std::size_t>(j) + static_cast<std::size_t>(by_) * k);
  }
  int nx_ = 0, ny_ = 0, nz_ = 0;  // the volume's dimensions (fits)
  int bx_ = 0, by_ = 0, bz_ = 0;
  std::vector<std::uint8_t> empty_;
};

namespace detail {
/// The parameter where `ray` enters (entering = true) or leaves block (b[0], b[1], b[2]), with
/// every face moved 1e-6 voxel inwards: a sample strictly between the two maps, after rounding,
/// to a cell of that block.
inline double block_face(const IndexRay& ray, const glm::dvec3& inverse_direction, const int b[3],
                         bool entering) {
  constexpr int B = EmptyBlocks::kSize;
  double t =
      entering ? -std::numeric_limits<double>::infinity() : std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    const double d = ray.direction[a];
    if (d == 0.0) continue;
    const bool low_face = (d > 0) == entering;
    const double face = low_face ? b[a] * B + 1e-6 : (b[a] + 1) * B - 1e-6;
    const double ta = (face - ray.origin[a]) * inverse_direction[a];
    t = entering ? std::max(t, ta) : std::min(t, ta);
  }
  return t;
}
}  // namespace detail

/// Calls take(k0, k1) for the runs [k0, k1) of the samples k in [k_begin, k_end), at
/// s_k = s0 + (k + 0.5) step, that are not in empty blocks, in order. Every sample must lie in
/// the interior (its base cell inside the grid). A 3D DDA visits the blocks along the ray at a
/// few cycles each; sample indices are only computed where the ray enters or leaves a run of
/// empty blocks.
template <class Take>
void for_each_occupied_run(const EmptyBlocks& empty, const IndexRay& ray, double s0, double step,
                           std::int64_t k_begin, std::int64_t k_end, Take&& take) {
  if (k_begin >= k_end) return;
  auto s_of = [&](std::int64_t k) { return s0 + (double(k) + 0.5) * step; };
  // The first sample at or after parameter t, within [lo, k_end].
  auto first_at = [&](double t, std::int64_t lo) {
    const double k = std::ceil((t - s0) / step - 0.5);
    return k >= double(k_end) ? k_end : std::max(lo, static_cast<std::int64_t>(k));
  };
  const glm::dvec3 inverse_direction = 1.0 / ray.direction;
  const double s_first = s_of(k_begin), s_last = s_of(k_end - 1);
  int b[3], b_step[3];
  double t_next[3], t_delta[3];
  for (int a = 0; a < 3; ++a) {
    const double d = ray.direction[a];
    const int cell = static_cast<int>(ray.origin[a] + s_first * d);
    b[a] = cell >> EmptyBlocks::kShift;
    b_step[a] = d > 0 ? 1 : -1;
    t_delta[a] = d == 0 ? 0.0 : std::abs(EmptyBlocks::kSize * inverse_direction[a]);
    t_next[a] = d == 0 ? std::numeric_limits<double>::infinity()
                       : ((d > 0 ? b[a] + 1 : b[a]) * EmptyBlocks::kSize - ray.origin[a]) *
                             inverse_direction[a];
  }
  std::int64_t run_begin = k_begin, skip_from = k_begin;
  bool skipping = false;
  int last_empty[3] = {0, 0, 0};
  while (true) {
    if (empty.empty_block(b[0], b[1], b[2])) {
      if (!skipping) {
        skip_from = first_at(detail::block_face(ray, inverse_direction, b, true), run_begin);
        take(run_begin, skip_from);
        skipping = true;
      }
      std::copy(b, b + 3, last_empty);
    } else if (skipping) {
      run_begin = std::max(
          skip_from,
          first_at(detail::block_face(ray, inverse_direction, last_empty, false), skip_from));
      skipping = false;
    }
    const int a = t_next[0] <= t_next[1] ? (t_next[0] <= t_next[2] ? 0 : 2)
                                         : (t_next[1] <= t_next[2] ? 1 : 2);
    if (t_next[a] > s_last) break;  // the remaining samples are all in this block
    b[a] += b_step[a];
    t_next[a] += t_delta[a];
    if (!empty.contains_block(b[0], b[1], b[2])) break;  // round-off at the grid's edge
  }
  if (!skipping) take(run_begin, k_end);
}

/// Calls take(s0, s1) for the parameter intervals of [s_begin, s_end] (both finite) where `ray`
/// (index space: voxel i centred on i) is not inside an empty block, in order, merging
/// neighbouring occupied blocks. Points before the first block or past the last (the outer half
/// voxel) belong to the edge block, whose voxels include the edge voxels. The integral of a
/// piecewise-constant volume over the skipped intervals is exactly zero, so an exact projector
/// summed over these intervals gives the whole ray's integral (up to rounding).
template <class Take>
void for_each_occupied_interval(const EmptyBlocks& empty, const IndexRay& ray, double s_begin,
                                double s_end, Take&& take) {
  if (!(s_begin < s_end)) return;
  constexpr int B = EmptyBlocks::kSize;
  int b[3], b_step[3];
  double t_next[3], t_delta[3];
  const glm::dvec3 start = ray.origin + s_begin * ray.direction;
  for (int a = 0; a < 3; ++a) {
    const double d = ray.direction[a];
    b[a] = std::clamp(static_cast<int>(std::floor(start[a] / B)), 0, empty.blocks(a) - 1);
    b_step[a] = d > 0 ? 1 : -1;
    // Crossings of the inner block faces only: past the edge blocks there is nothing to enter.
    const int face = d > 0 ? b[a] + 1 : b[a];
    const bool inner = d > 0 ? face < empty.blocks(a) : face > 0;
    t_delta[a] = d == 0 ? 0.0 : std::abs(B / d);
    t_next[a] = d == 0 || !inner ? std::numeric_limits<double>::infinity()
                                 : std::max(s_begin, (face * B - ray.origin[a]) / d);
  }
  double run_begin = s_begin;
  bool occupied = false;  // inside a run of occupied blocks that started at run_begin
  double t = s_begin;
  while (t < s_end) {
    const int a = t_next[0] <= t_next[1] ? (t_next[0] <= t_next[2] ? 0 : 2)
                                         : (t_next[1] <= t_next[2] ? 1 : 2);
    const double t_out = std::min(t_next[a], s_end);
    const bool is_empty = empty.empty_block(b[0], b[1], b[2]);
    if (!is_empty && !occupied) run_begin = t;
    if (is_empty && occupied) take(run_begin, t);
    occupied = !is_empty;
    t = t_out;
    if (t >= s_end) break;
    b[a] += b_step[a];
    const int face = b_step[a] > 0 ? b[a] + 1 : b[a];
    t_next[a] = (b_step[a] > 0 ? face < empty.blocks(a) : face > 0)
                    ? t_next[a] + t_delta[a]
                    : std::numeric_limits<double>::infinity();
  }
  if (occupied) take(run_begin, s_end);
}

}  // namespace gimm
