#pragma once
// Rays that meet the voxel lattice where the exact traversal is most fragile: through points of
// the grid's boundary that lie on voxel faces, edges and corners, axis-parallel rays in the
// boundary planes, and rays that start or end on a corner. Shared by the boundary tests and the
// traversal fuzz target. Random rays never hit these sets (they have measure zero), which is
// why the random-ray tests missed the out-of-grid read fixed in render/siddon.hpp.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include "gimm/core/rng.hpp"
#include "gimm/core/volume.hpp"
#include "gimm/render/ray_volume.hpp"
#include "gimm/render/siddon.hpp"

namespace gimm::test {

/// A source of choices: the tests draw them from an Rng, the fuzz target from its input bytes.
template <class Source>
double pick_uniform(Source& src, double lo, double hi) {
  return src.uniform(lo, hi);
}

/// How a boundary point meets the lattice: inside a face, on an edge of the voxel lattice
/// (one more coordinate on a voxel plane) or on a lattice corner (all coordinates on planes).
enum class Contact { face, edge, corner };

/// A coordinate on a voxel plane of an axis with n voxels: k - 0.5, k in [0, n] (index space).
template <class Source>
double lattice_plane(Source& src, int n) {
  return static_cast<double>(src.uniform_int(0, n)) - 0.5;
}

/// A point on the boundary of the grid [-0.5, n - 0.5]^3 of `dims` with the given contact.
template <class Source>
Eigen::Vector3d boundary_point(Source& src, const Eigen::Vector3i& dims, Contact contact) {
  const int axis = static_cast<int>(src.uniform_int(0, 2));
  Eigen::Vector3d p;
  p[axis] = src.uniform_int(0, 1) ? dims[axis] - 0.5 : -0.5;
  const int u = (axis + 1) % 3, w = (axis + 2) % 3;
  const bool swap = src.uniform_int(0, 1) == 1;  // which free axis gets the edge
  const int first = swap ? w : u, second = swap ? u : w;
  p[first] = contact == Contact::face ? pick_uniform(src, -0.5, dims[first] - 0.5)
                                      : lattice_plane(src, dims[first]);
  p[second] = contact == Contact::corner ? lattice_plane(src, dims[second])
                                         : pick_uniform(src, -0.5, dims[second] - 0.5);
  return p;
}

template <class Source>
Contact any_contact(Source& src) {
  return static_cast<Contact>(src.uniform_int(0, 2));
}

/// A ray in index space (origin, direction) that crosses the boundary at `p` and `q`, started
/// `back` ray-lengths before p (back = 0: the ray starts exactly on p).
inline IndexRay ray_through(const Eigen::Vector3d& p, const Eigen::Vector3d& q, double back) {
  const Eigen::Vector3d d = q - p;
  const Eigen::Vector3d o = p - back * d;
  return {glm::dvec3(o.x(), o.y(), o.z()), glm::dvec3(d.x(), d.y(), d.z())};
}

/// One ray of the fragile families, in index space of a grid of `dims`:
///   0 - boundary point to boundary point (entering and leaving on faces, edges, corners)
///   1 - axis-parallel, lying in a boundary plane or on a boundary edge of the grid
///   2 - starting exactly on a lattice corner of the boundary, going inwards
///   3 - from inside to a lattice corner of the boundary, leaving there
template <class Source>
IndexRay fragile_ray(Source& src, const Eigen::Vector3i& dims) {
  const int family = static_cast<int>(src.uniform_int(0, 3));
  if (family == 1) {
    const int axis = static_cast<int>(src.uniform_int(0, 2));
    const int u = (axis + 1) % 3, w = (axis + 2) % 3;
    Eigen::Vector3d o, d = Eigen::Vector3d::Zero();
    o[axis] = src.uniform_int(0, 1) ? -3.0 : dims[axis] + 2.0;
    d[axis] = o[axis] < 0 ? 1.0 : -1.0;
    o[u] = src.uniform_int(0, 1) ? dims[u] - 0.5 : -0.5;        // in a boundary plane ...
    o[w] = src.uniform_int(0, 1) ? lattice_plane(src, dims[w])  // ... on an edge, or not
                                 : pick_uniform(src, -0.5, dims[w] - 0.5);
    if (src.uniform_int(0, 1)) std::swap(o[u], o[w]);
    return {glm::dvec3(o.x(), o.y(), o.z()), glm::dvec3(d.x(), d.y(), d.z())};
  }
  const Eigen::Vector3d inside(pick_uniform(src, -0.5, dims[0] - 0.5),
                               pick_uniform(src, -0.5, dims[1] - 0.5),
                               pick_uniform(src, -0.5, dims[2] - 0.5));
  // Two points that coincide give no direction: then the ray runs to the opposite corner.
  auto apart = [&](const Eigen::Vector3d& p, const Eigen::Vector3d& q) {
    return (q - p).norm() > 1e-6
               ? q
               : Eigen::Vector3d(dims.cast<double>()) - p - Eigen::Vector3d::Ones();
  };
  if (family == 2) {
    const Eigen::Vector3d corner = boundary_point(src, dims, Contact::corner);
    return ray_through(corner, apart(corner, inside), 0.0);
  }
  if (family == 3) {
    const Eigen::Vector3d corner = boundary_point(src, dims, Contact::corner);
    return ray_through(apart(corner, inside), corner, 2.0);
  }
  const Eigen::Vector3d p = boundary_point(src, dims, any_contact(src));
  const Eigen::Vector3d q = apart(p, boundary_point(src, dims, any_contact(src)));
  return ray_through(p, q, src.uniform_int(0, 1) ? 3.0 : 0.5);
}

/// The same ray taken through a world geometry and back: the round trip through spacing,
/// origin and direction cosines is inexact, so crossings that coincide in index space arrive a
/// few ulps apart (as with real scanner geometries).
inline IndexRay through_world(const VolumeGeometry& g, const IndexRay& r) {
  const Eigen::Vector3d o = g.index_to_world(Eigen::Vector3d(r.origin.x, r.origin.y, r.origin.z));
  const Eigen::Vector3d d =
      g.index_to_world_matrix() * Eigen::Vector3d(r.direction.x, r.direction.y, r.direction.z);
  return to_index_ray(g, Ray<double>{o, d.normalized()});
}

/// World geometries with the spacings and origins of real scans: a chest CT's 0.9765625 x
/// 0.9765625 x 2 mm stored RAS-first (x and y flipped), anisotropic non-dyadic spacing with a
/// rotation, and unit voxels.
inline VolumeGeometry scanner_geometry(int which, const Eigen::Vector3i& dims) {
  VolumeGeometry g;
  g.dims = {dims[0], dims[1], dims[2]};
  switch (which % 3) {
    case 0:
      g.spacing = Eigen::Vector3d(0.9765625, 0.9765625, 2.0);
      g.direction = Eigen::Vector3d(-1, -1, 1).asDiagonal();
      g.origin = Eigen::Vector3d(249.51171875, 437.51171875, -804.5);
      break;
    case 1:
      g.spacing = Eigen::Vector3d(0.7, 0.5, 1.2);
      g.direction =
          Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
      g.origin = Eigen::Vector3d(-3.1, 2.7, 5.3);
      break;
    default:
      break;
  }
  return g;
}

/// The chord (in the ray's s units) of `r` through the index box of the grid, from s >= 0:
/// the exact integral of a volume of ones. Written out per slab, independently of clip_to_box,
/// in the traversal's frame (voxel i spans [i, i+1) after adding 0.5), so that a ray grazing a
/// boundary face rounds the same way in both.
inline double index_box_chord(const IndexRay& r, const Eigen::Vector3i& dims) {
  double s0 = 0.0, s1 = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    const double o = r.origin[a] + 0.5, hi = dims[a];
    if (r.direction[a] == 0.0) {
      if (o < 0.0 || o >= hi) return 0.0;  // half-open: the high face has no voxel
      continue;
    }
    const double t0 = (0.0 - o) / r.direction[a], t1 = (hi - o) / r.direction[a];
    s0 = std::max(s0, std::min(t0, t1));
    s1 = std::min(s1, std::max(t0, t1));
  }
  return std::max(0.0, s1 - s0);
}

/// The range of integrals that a ray within `eps` index units of itself can give: Siddon's
/// sorted crossings, but where a segment's midpoint lies within `eps` of a voxel plane (the ray
/// runs along a face, up to round-off) either voxel is a right answer, so the segment adds its
/// length times the smallest and the largest candidate value. The oracle for rays that the
/// round trip through a world geometry leaves a few ulps off a face; rays exactly in a face
/// follow the [i, i+1) rule, tested on their own.
template <class T>
std::pair<double, double> siddon_integral_bounds(const Volume<T>& volume, const IndexRay& ray,
                                                 double eps = 1e-9) {
  const glm::dvec3 o = ray.origin + 0.5;
  const glm::dvec3& d = ray.direction;
  const int n[3] = {volume.nx(), volume.ny(), volume.nz()};
  const std::vector<double> s_all = detail::sorted_crossings(volume, ray, 0.0);
  double lo = 0.0, hi = 0.0;
  for (std::size_t m = 0; m + 1 < s_all.size(); ++m) {
    const double length = s_all[m + 1] - s_all[m];
    if (length <= 0) continue;
    const double s_mid = 0.5 * (s_all[m] + s_all[m + 1]);
    int first[3], last[3];
    for (int a = 0; a < 3; ++a) {
      const double p = o[a] + s_mid * d[a];
      first[a] = std::clamp(static_cast<int>(std::floor(p - eps)), 0, n[a] - 1);
      last[a] = std::clamp(static_cast<int>(std::floor(p + eps)), 0, n[a] - 1);
    }
    double v_min = std::numeric_limits<double>::infinity(), v_max = -v_min;
    for (int k = first[2]; k <= last[2]; ++k)
      for (int j = first[1]; j <= last[1]; ++j)
        for (int i = first[0]; i <= last[0]; ++i) {
          v_min = std::min(v_min, static_cast<double>(volume(i, j, k)));
          v_max = std::max(v_max, static_cast<double>(volume(i, j, k)));
        }
    lo += length * v_min;
    hi += length * v_max;
  }
  return {lo, hi};
}

}  // namespace gimm::test
