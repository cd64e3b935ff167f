#pragma once
/// Volume<T>: a 3D voxel grid placed in world space (patient LPS, millimetres).
///
/// Indexed (i, j, k) with i fastest in memory, as NIfTI stores it: data()[i + nx * (j + ny * k)].
/// Voxel (i, j, k) has its centre at
///   world = origin + direction * diag(spacing) * (i, j, k)^T
/// so `origin` is the centre of voxel (0, 0, 0) and the columns of `direction` are the unit
/// world directions of the i, j, k axes. Invariants: spacing > 0 and finite; direction is
/// orthonormal (det +-1). The voxel model treats each voxel as a box of size `spacing` centred
/// on its centre, so the volume covers index coordinates [-0.5, n - 0.5] on each axis.
#include <Eigen/Core>
#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/core/huge_pages.hpp"

namespace gimm {

struct VolumeGeometry {
  std::array<int, 3> dims{0, 0, 0};
  Eigen::Vector3d spacing{1.0, 1.0, 1.0};  ///< mm per voxel along i, j, k
  Eigen::Vector3d origin{0.0, 0.0, 0.0};   ///< world mm of the centre of voxel (0, 0, 0)
  Eigen::Matrix3d direction = Eigen::Matrix3d::Identity();  ///< columns: world axes of i, j, k

  std::int64_t voxel_count() const {
    return static_cast<std::int64_t>(dims[0]) * dims[1] * dims[2];
  }
  /// index -> world matrix A (world = origin + A * ijk).
  Eigen::Matrix3d index_to_world_matrix() const { return direction * spacing.asDiagonal(); }
  Eigen::Vector3d index_to_world(const Eigen::Vector3d& ijk) const {
    return origin + index_to_world_matrix() * ijk;
  }
  Eigen::Vector3d world_to_index(const Eigen::Vector3d& world) const {
    // direction is orthonormal, so A^-1 = diag(1/spacing) * direction^T.
    return spacing.cwiseInverse().asDiagonal() * (direction.transpose() * (world - origin));
  }
  /// True when the continuous index lies in the voxel model [-0.5, n - 0.5]^3.
  bool contains_index(const Eigen::Vector3d& ijk) const {
    for (int a = 0; a < 3; ++a)
      if (!(ijk[a] >= -0.5 && ijk[a] <= dims[a] - 0.5)) return false;
    return true;
  }

  /// Throws gimm::Error naming `what` if dims, spacing, origin or direction are invalid.
  void validate(const char* what) const {
    for (int a = 0; a < 3; ++a) {
      GIMM_CHECK(dims[a] > 0 && dims[a] <= 65536,
                 what << ": dimension " << a << " must be in [1, 65536], got " << dims[a]);
      // Bounds far beyond any scanner (0.1 um to 10 m voxels, 10 km from the origin): past them
      // the cameras and rays built on the grid lose every digit and fail far from the cause.
      GIMM_CHECK(std::isfinite(spacing[a]) && spacing[a] >= 1e-4 && spacing[a] <= 1e4,
                 what << ": spacing " << a << " must be in [1e-4, 1e4] mm, got " << spacing[a]);
      GIMM_CHECK(std::isfinite(origin[a]) && std::abs(origin[a]) <= 1e7,
                 what << ": origin " << a << " must be within +-1e7 mm, got " << origin[a]);
    }
    GIMM_CHECK(direction.allFinite(), what << ": direction has non-finite entries");
    const double orthonormality =
        (direction.transpose() * direction - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
    GIMM_CHECK(orthonormality < 1e-4,
               what << ": direction is not orthonormal (|D^T D - I| = " << orthonormality << ")");
  }
};

/// How grid `b` differs from grid `a` ("" when they describe the same voxels): dimensions,
/// then spacing (1e-4 mm), origin (1e-3 mm) and axis directions (1e-4), as "what: a vs b".
inline std::string grid_difference(const VolumeGeometry& a, const VolumeGeometry& b) {
  std::ostringstream out;
  const auto differ = [&](const std::string& what, const Eigen::Vector3d& x,
                          const Eigen::Vector3d& y) {
    out << what << " (" << x[0] << ", " << x[1] << ", " << x[2] << ") vs (" << y[0] << ", " << y[1]
        << ", " << y[2] << ")";
  };
  if (a.dims != b.dims) {
    out << "dimensions " << a.dims[0] << "x" << a.dims[1] << "x" << a.dims[2] << " vs " << b.dims[0]
        << "x" << b.dims[1] << "x" << b.dims[2];
  } else if ((a.spacing - b.spacing).cwiseAbs().maxCoeff() > 1e-4) {
    differ("spacing", a.spacing, b.spacing);
  } else if ((a.origin - b.origin).cwiseAbs().maxCoeff() > 1e-3) {
    differ("origin", a.origin, b.origin);
  } else {
    for (int axis = 0; axis < 3; ++axis)
      if ((a.direction.col(axis) - b.direction.col(axis)).cwiseAbs().maxCoeff() > 1e-4) {
        differ("direction of axis " + std::to_string(axis), a.direction.col(axis),
               b.direction.col(axis));
        break;
      }
  }
  return out.str();
}

/// The one grid check of an image and its label (the dataset, gimm-drr, the renderer): throws
/// unless they share dims, spacing, origin and direction, naming `what` and the first difference.
inline void check_same_grid(const VolumeGeometry& image, const VolumeGeometry& label,
                            const std::string& what) {
  const std::string difference = grid_difference(image, label);
  GIMM_CHECK(difference.empty(), what << ": image and label grids disagree: " << difference);
}

/// Owns its voxels (a std::vector), or, made by Volume::view, reads and writes a buffer it does
/// not own (a numpy array, a memory-mapped file): a zero-copy input. Every function that takes a
/// Volume takes a view alike. Copies always own their voxels (a copy of a view is a deep copy);
/// a moved view stays a view. The buffer must outlive the view and its moves.
template <class T>
class Volume {
 public:
  Volume() = default;
  explicit Volume(const VolumeGeometry& geometry, T fill = T{}) : geometry_(geometry) {
    geometry_.validate("Volume");
    reserve_huge(own_, static_cast<std::size_t>(geometry_.voxel_count()));
    own_.assign(static_cast<std::size_t>(geometry_.voxel_count()), fill);
    data_ = own_.data();
    size_ = own_.size();
  }
  /// A view over `data`: geometry.voxel_count() voxels, i fastest (data[i + nx * (j + ny * k)]).
  static Volume view(const VolumeGeometry& geometry, T* data) {
    geometry.validate("Volume view");
    GIMM_CHECK(data != nullptr, "Volume view: no buffer (null pointer)");
    Volume v;
    v.geometry_ = geometry;
    v.data_ = data;
    v.size_ = static_cast<std::size_t>(geometry.voxel_count());
    return v;
  }

  Volume(const Volume& other) : geometry_(other.geometry_) {
    reserve_huge(own_, other.size_);
    own_.assign(other.data_, other.data_ + other.size_);
    data_ = own_.data();
    size_ = own_.size();
  }
  Volume(Volume&& other) noexcept { swap(other); }
  Volume& operator=(Volume other) noexcept {
    swap(other);
    return *this;
  }
  void swap(Volume& other) noexcept {
    std::swap(geometry_, other.geometry_);
    own_.swap(other.own_);  // the buffers keep their addresses: data_ stays valid
    std::swap(data_, other.data_);
    std::swap(size_, other.size_);
  }

  /// False for a view (Volume::view and its moves).
  bool owns_data() const { return data_ == nullptr || data_ == own_.data(); }

  const VolumeGeometry& geometry() const { return geometry_; }
  const std::array<int, 3>& dims() const { return geometry_.dims; }
  int nx() const { return geometry_.dims[0]; }
  int ny() const { return geometry_.dims[1]; }
  int nz() const { return geometry_.dims[2]; }
  const Eigen::Vector3d& spacing() const { return geometry_.spacing; }
  const Eigen::Vector3d& origin() const { return geometry_.origin; }
  const Eigen::Matrix3d& direction() const { return geometry_.direction; }
  std::size_t size() const { return size_; }

  std::size_t linear_index(int i, int j, int k) const {
    return static_cast<std::size_t>(i) +
           static_cast<std::size_t>(nx()) *
               (static_cast<std::size_t>(j) + static_cast<std::size_t>(ny()) * k);
  }
  bool contains(int i, int j, int k) const {
    return i >= 0 && j >= 0 && k >= 0 && i < nx() && j < ny() && k < nz();
  }
  T& operator()(int i, int j, int k) {
    GIMM_ASSERT(contains(i, j, k));
    return data_[linear_index(i, j, k)];
  }
  const T& operator()(int i, int j, int k) const {
    GIMM_ASSERT(contains(i, j, k));
    return data_[linear_index(i, j, k)];
  }

  Eigen::Vector3d index_to_world(const Eigen::Vector3d& ijk) const {
    return geometry_.index_to_world(ijk);
  }
  Eigen::Vector3d world_to_index(const Eigen::Vector3d& world) const {
    return geometry_.world_to_index(world);
  }

  /// Trilinear interpolation at a continuous index; voxels outside the grid count as
  /// `outside` (0 by default), so the field falls off linearly across the border half-voxel.
  double sample_index(const Eigen::Vector3d& ijk, double outside = 0.0) const {
    const double fi = std::floor(ijk[0]), fj = std::floor(ijk[1]), fk = std::floor(ijk[2]);
    const int i0 = static_cast<int>(fi), j0 = static_cast<int>(fj), k0 = static_cast<int>(fk);
    const double di = ijk[0] - fi, dj = ijk[1] - fj, dk = ijk[2] - fk;
    double result = 0.0;
    for (int c = 0; c < 8; ++c) {
      const int i = i0 + (c & 1), j = j0 + ((c >> 1) & 1), k = k0 + ((c >> 2) & 1);
      const double w =
          ((c & 1) ? di : 1 - di) * (((c >> 1) & 1) ? dj : 1 - dj) * (((c >> 2) & 1) ? dk : 1 - dk);
      if (w == 0.0) continue;
      result += w * (contains(i, j, k) ? static_cast<double>((*this)(i, j, k)) : outside);
    }
    return result;
  }
  double sample_world(const Eigen::Vector3d& world, double outside = 0.0) const {
    return sample_index(world_to_index(world), outside);
  }

  T* data() { return data_; }
  const T* data() const { return data_; }
  T* begin() { return data_; }
  T* end() { return data_ + size_; }
  const T* begin() const { return data_; }
  const T* end() const { return data_ + size_; }
  /// The owned voxels as a vector (comparisons in tests, moving the buffer out); a view has none.
  std::vector<T>& storage() {
    check_owned();
    return own_;
  }
  const std::vector<T>& storage() const {
    check_owned();
    return own_;
  }

 private:
  void check_owned() const {
    GIMM_CHECK(owns_data(), "Volume: storage() of a view (it owns no vector; use begin()/end())");
  }

  VolumeGeometry geometry_;
  std::vector<T> own_;
  T* data_ = nullptr;
  std::size_t size_ = 0;
};

/// Element-wise conversion to another voxel type on the same grid (static_cast per voxel).
template <class To, class From>
Volume<To> volume_cast(const Volume<From>& in) {
  Volume<To> out(in.geometry());
  for (std::size_t n = 0; n < in.size(); ++n) out.data()[n] = static_cast<To>(in.data()[n]);
  return out;
}

/// The foreground's bounding box grown by `margin` voxels (clamped to the grid), as a 0/1
/// volume placed at the same world position. An empty mask gives a 1x1x1 empty volume.
template <class T>
Volume<std::uint8_t> crop_to_foreground(const Volume<T>& mask, int margin) {
  std::array<int, 3> lo{mask.nx(), mask.ny(), mask.nz()}, hi{-1, -1, -1};
  for (int k = 0; k < mask.nz(); ++k)
    for (int j = 0; j < mask.ny(); ++j)
      for (int i = 0; i < mask.nx(); ++i)
        if (mask(i, j, k) != T(0)) {
          const int idx[3] = {i, j, k};
          for (int a = 0; a < 3; ++a) {
            lo[a] = std::min(lo[a], idx[a]);
            hi[a] = std::max(hi[a], idx[a]);
          }
        }
  VolumeGeometry g = mask.geometry();
  if (hi[0] < 0) {
    g.dims = {1, 1, 1};
    return Volume<std::uint8_t>(g, 0);
  }
  for (int a = 0; a < 3; ++a) {
    lo[a] = std::max(0, lo[a] - margin);
    hi[a] = std::min(mask.dims()[a] - 1, hi[a] + margin);
    g.dims[a] = hi[a] - lo[a] + 1;
  }
  g.origin = mask.index_to_world(Eigen::Vector3d(lo[0], lo[1], lo[2]));
  Volume<std::uint8_t> out(g, 0);
  for (int k = 0; k < g.dims[2]; ++k)
    for (int j = 0; j < g.dims[1]; ++j)
      for (int i = 0; i < g.dims[0]; ++i)
        out(i, j, k) = mask(i + lo[0], j + lo[1], k + lo[2]) != T(0);
  return out;
}

}  // namespace gimm
