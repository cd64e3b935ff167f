#pragma once
/// The patient beyond the scan's axial coverage. A CCTA covers the heart (ImageCAS: 128 mm)
/// while a C-arm detector sees ~190 mm at the isocentre; rays that pass above or below the
/// volume would meet air and, after min-max normalisation, turn the image's top and bottom
/// white. The padding repeats the first and last slices along the head-foot axis (tissue,
/// spine and ribs carry on); docs/recipes.md.
///
/// - pad_axial: the padded volume itself (copies of the edge slices): the reference path.
/// - AxialPads: the same padding as two one-voxel slabs `pad_mm` thick beside the volume. The
///   padding is constant along the axis, and Siddon's voxel model is constant within a voxel, so
///   one thick voxel integrates exactly like many thin copies, at the cost of one slice instead
///   of pad_mm / spacing of them. render_line_integrals(mu, pads, ...) in drr.hpp adds them; the
///   plane where scan and pad meet belongs to one of them (clip_to_box's half-open rule).
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <optional>

#include "gimm/core/error.hpp"
#include "gimm/core/volume.hpp"

namespace gimm {

/// gimm-drr's and gimm-dataset's padding: enough for a 256 mm detector at magnification 1.33
/// (190 mm at the isocentre) over a 128 mm scan at +-30 degrees of cranial/caudal tilt through
/// the heart (docs/recipes.md).
inline constexpr double kDefaultPadMm = 80.0;

/// The index axis that runs head-foot: the one whose direction is closest to world z.
inline int axial_axis(const VolumeGeometry& g) {
  int best = 0;
  for (int a = 1; a < 3; ++a)
    if (std::abs(g.direction(2, a)) > std::abs(g.direction(2, best))) best = a;
  return best;
}

/// The thinnest padding accepted (other than 0, none): a pad is one voxel of pad_mm, and a
/// denormal-thin voxel would make the traversal's 1 / spacing infinite.
inline constexpr double kMinPadMm = 0.01;

namespace detail {
inline void check_pad(double pad_mm) {
  GIMM_CHECK(pad_mm == 0 || (std::isfinite(pad_mm) && pad_mm >= kMinPadMm && pad_mm <= 1000),
             "axial padding must be 0 or in [" << kMinPadMm << ", 1000] mm, got " << pad_mm);
}

/// `count` voxels of `spacing` along the axial `axis`, the first centred `first_centre_mm` from
/// the volume's origin along that axis, each a copy of the volume's slice `source`.
template <class T>
Volume<T> slices_like(const Volume<T>& volume, int axis, int count, double spacing,
                      double first_centre_mm, int source) {
  VolumeGeometry g = volume.geometry();
  g.dims[axis] = count;
  g.spacing[axis] = spacing;
  g.origin = volume.geometry().origin + g.direction.col(axis) * first_centre_mm;
  Volume<T> out(g);
  for (int k = 0; k < out.nz(); ++k)
    for (int j = 0; j < out.ny(); ++j)
      for (int i = 0; i < out.nx(); ++i) {
        int idx[3] = {i, j, k};
        idx[axis] = source;
        out(i, j, k) = volume(idx[0], idx[1], idx[2]);
      }
  return out;
}
}  // namespace detail

/// `volume` with `pad_mm` more on both axial sides, as copies of its first and last slices or,
/// given `fill`, that value (a label that must not carry on). Whole voxels: the pad is rounded up
/// to a multiple of the slice spacing, unlike axial_pads. pad_mm = 0 returns the volume unchanged.
template <class T>
Volume<T> pad_axial(Volume<T> volume, double pad_mm, std::optional<T> fill = std::nullopt) {
  detail::check_pad(pad_mm);
  VolumeGeometry g = volume.geometry();
  const int axis = axial_axis(g);
  const int pad = static_cast<int>(std::ceil(pad_mm / g.spacing[axis] - 1e-9));
  if (pad == 0) return volume;  // moved, not copied
  g.dims[axis] += 2 * pad;
  g.origin -= g.direction.col(axis) * (g.spacing[axis] * pad);
  Volume<T> out(g);
  const int n_axis = volume.geometry().dims[axis];
  for (int k = 0; k < out.nz(); ++k)
    for (int j = 0; j < out.ny(); ++j)
      for (int i = 0; i < out.nx(); ++i) {
        int idx[3] = {i, j, k};
        const int source = idx[axis] - pad;
        idx[axis] = std::clamp(source, 0, n_axis - 1);
        out(i, j, k) = fill && source != idx[axis] ? *fill : volume(idx[0], idx[1], idx[2]);
      }
  return out;
}

/// The padding of pad_axial as two slabs, one voxel of `pad_mm` (exactly) along the axial axis
/// each, adjoining the volume's first and last slices without overlap. Only the exact projector
/// integrates them like the padded volume: the trilinear field of a one-voxel slab fades over
/// half its thickness (padded_attenuation.hpp picks the form per projector).
template <class T>
struct AxialPads {
  Volume<T> below, above;
  bool empty() const { return below.size() == 0; }
};

template <class T>
AxialPads<T> axial_pads(const Volume<T>& volume, double pad_mm) {
  detail::check_pad(pad_mm);
  if (pad_mm == 0) return {};
  const int axis = axial_axis(volume.geometry());
  const double s = volume.geometry().spacing[axis];
  const int n = volume.geometry().dims[axis];
  return {detail::slices_like(volume, axis, 1, pad_mm, -0.5 * s - 0.5 * pad_mm, 0),
          detail::slices_like(volume, axis, 1, pad_mm, (n - 0.5) * s + 0.5 * pad_mm, n - 1)};
}

}  // namespace gimm
