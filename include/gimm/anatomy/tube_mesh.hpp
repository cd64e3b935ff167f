#pragma once
/// A closed triangle mesh of a coronary tree's analytic tubes: each branch swept as a polygon
/// ring at every centerline sample (its radius there) and closed at both ends by a hemisphere
/// of the end's radius (4 rings and a pole: a vessel ends rounded, and its last centreline
/// point lies a radius inside the lumen in every direction, as every other). For phantoms,
/// whose tubes are known exactly: mesh_from_mask of their label is a voxel surface (1.6 mm
/// steps on the small grids, a staircase at 0.3 mm detector pixels), this is the lumen itself.
///
/// Branches overlap where a child leaves its parent (its first ring lies inside the parent):
/// the mesh is a union of closed surfaces, which the Embree projector's signed-crossing count
/// images as one (vessel_mesh_projector.hpp). Ring radii are scaled so a ring's polygon has the
/// circle's area (r sqrt(2 pi / (n sin(2 pi / n)))): volumes and mean chords are the tube's.
/// Ring frames are parallel-transported along the branch, so a ring does not twist.
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "gimm/anatomy/centerlines.hpp"
#include "gimm/anatomy/vessel_mesh.hpp"
#include "gimm/core/constants.hpp"
#include "gimm/core/error.hpp"

namespace gimm {

namespace detail {

/// A unit vector perpendicular to unit `t`.
inline Eigen::Vector3d any_perpendicular(const Eigen::Vector3d& t) {
  const Eigen::Vector3d axis =
      std::abs(t.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  return t.cross(axis).normalized();
}

/// One ring of a tube: its centre, radius and frame (normal, binormal; tangent = n x b).
struct TubeRing {
  Eigen::Vector3d centre, normal, binormal;
  double radius;
};

/// The rings of one branch: one per sample, parallel-transported, and kCapRings more at each
/// end closing it as a hemisphere (a centreline's last point is then inside its lumen by a
/// radius in every direction, as at any other point).
struct TubeRings {
  std::vector<TubeRing> rings;
  Eigen::Vector3d start_pole, end_pole;  ///< the hemispheres' tips
};

inline TubeRings tube_rings(const CenterlineBranch& br) {
  constexpr int kCapRings = 4;
  const std::size_t n = br.points.size();
  std::vector<TubeRing> body;
  Eigen::Vector3d normal;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d tangent =
        (br.points[std::min(i + 1, n - 1)] - br.points[i == 0 ? 0 : i - 1]).normalized();
    // Parallel transport: the previous normal, made perpendicular to this tangent.
    normal =
        i == 0 ? any_perpendicular(tangent) : (normal - normal.dot(tangent) * tangent).normalized();
    if (!normal.allFinite() || normal.squaredNorm() < 0.5) normal = any_perpendicular(tangent);
    body.push_back({br.points[i], normal, tangent.cross(normal), br.radii[i]});
  }
  TubeRings out;
  std::vector<TubeRing>& rings = out.rings;
  const auto cap = [&](const TubeRing& end, double direction, int k) {  // k = 1..kCapRings
    const double phi = kPi / 2 * k / (kCapRings + 1);
    const Eigen::Vector3d tangent = end.normal.cross(end.binormal);
    return TubeRing{end.centre + direction * end.radius * std::sin(phi) * tangent, end.normal,
                    end.binormal, end.radius * std::cos(phi)};
  };
  for (int k = kCapRings; k >= 1; --k) rings.push_back(cap(body.front(), -1, k));
  rings.insert(rings.end(), body.begin(), body.end());
  for (int k = 1; k <= kCapRings; ++k) rings.push_back(cap(body.back(), +1, k));
  const auto tip = [](const TubeRing& end, double direction) -> Eigen::Vector3d {
    return end.centre + direction * end.radius * end.normal.cross(end.binormal);
  };
  out.start_pole = tip(body.front(), -1);
  out.end_pole = tip(body.back(), +1);
  return out;
}

/// Appends one branch's tube (rings, side quads, two hemispherical caps), outward-facing.
inline void append_tube(const CenterlineBranch& br, int sides, TriangleMesh& mesh) {
  const TubeRings tube = tube_rings(br);
  const std::vector<TubeRing>& rings = tube.rings;
  const std::size_t n = rings.size();
  const double area_scale = std::sqrt(2 * kPi / (sides * std::sin(2 * kPi / sides)));
  const auto base = static_cast<std::uint32_t>(mesh.vertices.size());
  for (const TubeRing& ring : rings)
    for (int s = 0; s < sides; ++s) {
      const double a = 2 * kPi * s / sides;
      mesh.vertices.push_back(
          (ring.centre +
           ring.radius * area_scale * (std::cos(a) * ring.normal + std::sin(a) * ring.binormal))
              .cast<float>());
    }
  const auto at = [&](std::size_t i, int s) {
    return base + static_cast<std::uint32_t>(i * sides + (s % sides));
  };
  // s turns from the normal towards the binormal (tangent = normal x binormal), so
  // (i, s) -> (i, s + 1) -> (i + 1, s + 1) faces outward.
  for (std::size_t i = 0; i + 1 < n; ++i)
    for (int s = 0; s < sides; ++s) {
      mesh.triangles.push_back({at(i, s), at(i, s + 1), at(i + 1, s + 1)});
      mesh.triangles.push_back({at(i, s), at(i + 1, s + 1), at(i + 1, s)});
    }
  const auto first = static_cast<std::uint32_t>(mesh.vertices.size());
  mesh.vertices.push_back(tube.start_pole.cast<float>());
  mesh.vertices.push_back(tube.end_pole.cast<float>());
  for (int s = 0; s < sides; ++s) {
    mesh.triangles.push_back({first, at(0, s + 1), at(0, s)});              // faces back
    mesh.triangles.push_back({first + 1, at(n - 1, s), at(n - 1, s + 1)});  // faces ahead
  }
}

}  // namespace detail

namespace detail {

/// Moves each interior sample where the path bends tighter than max(1.25 radius, min_bend_mm)
/// to its neighbours' mean, round after round (at most max_rounds) until none is; the ends stay.
inline void relax_bends(std::vector<Eigen::Vector3d>& points, const std::vector<double>& radii,
                        double min_bend_mm, int max_rounds) {
  for (int round = 0; round < max_rounds; ++round) {
    bool moved = false;
    for (std::size_t i = 1; i + 1 < points.size(); ++i) {
      const Eigen::Vector3d a = points[i] - points[i - 1], c = points[i + 1] - points[i];
      const double cos_turn = a.dot(c) / std::max(1e-12, a.norm() * c.norm());
      const double turn = std::acos(std::clamp(cos_turn, -1.0, 1.0));
      const double bend_radius = 0.5 * (a.norm() + c.norm()) / std::max(1e-12, turn);
      if (bend_radius >= std::max(1.25 * radii[i], min_bend_mm)) continue;
      points[i] = 0.5 * (points[i - 1] + points[i + 1]);
      moved = true;
    }
    if (!moved) return;
  }
}

}  // namespace detail

/// The axes a tube mesh can follow without folding: each branch resampled every `step_mm` of
/// arc length (radii interpolated), then relaxed where it bends tighter than its own radius
/// (a swept circle folds over itself on the inside of a bend whose radius of curvature is
/// below the tube's: the phantom's paths have sub-voxel zigzags and, where the proximal RCA
/// meets its groove path, a 2-4 mm jump that doubles back). Relaxing moves a sample to its
/// neighbours' mean, only where needed, up to 200 rounds; the ends stay (a child still starts
/// on its parent). Where tubes are imaged and labelled (gimm-dataset --vessels tubes) these are
/// the labelled centerlines, so labels and lumen agree exactly.
inline CenterlineTree tube_axes(const CenterlineTree& tree, double step_mm = 0.5) {
  tree.validate("tube_axes");
  GIMM_CHECK(std::isfinite(step_mm) && step_mm > 0,
             "tube_axes: step_mm must be > 0, got " << step_mm);
  CenterlineTree out = tree;
  for (auto& b : out.branches) {
    // Resample at uniform arc length.
    std::vector<double> s(b.points.size(), 0.0);
    for (std::size_t i = 1; i < b.points.size(); ++i)
      s[i] = s[i - 1] + (b.points[i] - b.points[i - 1]).norm();
    const int n = std::max(2, static_cast<int>(std::ceil(s.back() / step_mm)) + 1);
    std::vector<Eigen::Vector3d> points;
    std::vector<double> radii;
    std::size_t seg = 1;
    for (int k = 0; k < n; ++k) {
      const double at = s.back() * k / (n - 1);
      while (seg + 1 < s.size() && s[seg] < at) ++seg;
      const double span = s[seg] - s[seg - 1];
      const double t = span > 0 ? std::clamp((at - s[seg - 1]) / span, 0.0, 1.0) : 0.0;
      points.push_back(b.points[seg - 1] + t * (b.points[seg] - b.points[seg - 1]));
      radii.push_back(b.radii[seg - 1] + t * (b.radii[seg] - b.radii[seg - 1]));
    }
    detail::relax_bends(points, radii, 0.0, 200);
    b.points = std::move(points);
    b.radii = std::move(radii);
  }
  return out;
}

/// The tubes of `tree`'s branches of `system`, `sides` (>= 6) vertices per ring, following the
/// branches' points as given (tube_axes first for a tree that bends tighter than its radii).
inline TriangleMesh tube_mesh(const CenterlineTree& tree, CoronarySystem system, int sides = 16) {
  tree.validate("tube_mesh");
  GIMM_CHECK(sides >= 6 && sides <= 256, "tube_mesh: sides must be in [6, 256], got " << sides);
  TriangleMesh mesh;
  for (const auto& br : tree.branches)
    if (br.system == system) detail::append_tube(br, sides, mesh);
  GIMM_CHECK(!mesh.triangles.empty(),
             "tube_mesh: the tree has no branch of the " << to_string(system) << " system");
  return mesh;
}

}  // namespace gimm
