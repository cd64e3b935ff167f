#pragma once
/// Rays in the index space of a volume, and clipping to boxes.
///
/// A world ray origin + s * direction (unit direction, s in mm) maps to the volume's continuous
/// index space as o + s * d with o = A^-1 (origin - volume origin), d = A^-1 direction, where A is
/// the index->world matrix (direction cosines times spacing; volume.hpp). The parameter s keeps
/// measuring world millimetres along the ray, so lengths come out in mm for any voxel spacing
/// and any direction cosines (plastimatch ignores the latter).
/// In index space voxel (i, j, k) is centred on (i, j, k) and occupies [i-0.5, i+0.5] x ...
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <glm/common.hpp>
#include <glm/vec3.hpp>
#include <limits>

#include "gimm/core/volume.hpp"
#include "gimm/geometry/camera.hpp"

namespace gimm {

struct IndexRay {
  glm::dvec3 origin;     ///< continuous index coordinates at s = 0
  glm::dvec3 direction;  ///< index units per world mm
};

/// Maps world rays into one volume's index space (the matrix A^-1 computed once).
class IndexSpace {
 public:
  explicit IndexSpace(const VolumeGeometry& geometry)
      : inverse_(geometry.spacing.cwiseInverse().asDiagonal() * geometry.direction.transpose()),
        origin_(geometry.origin) {}
  IndexRay operator()(const Ray<double>& ray) const {
    const Eigen::Vector3d o = inverse_ * (ray.origin - origin_);
    const Eigen::Vector3d d = inverse_ * ray.direction;
    return {glm::dvec3(o.x(), o.y(), o.z()), glm::dvec3(d.x(), d.y(), d.z())};
  }

 private:
  Eigen::Matrix3d inverse_;
  Eigen::Vector3d origin_;
};

inline IndexRay to_index_ray(const VolumeGeometry& geometry, const Ray<double>& ray) {
  return IndexSpace(geometry)(ray);
}

/// Parameter interval [s_enter, s_exit] where the ray lies in the box lo <= p <= hi, restricted
/// to s >= s_min. Returns false on a miss (including grazing a box of zero thickness). An axis
/// the ray runs parallel to constrains nothing if the origin lies in the half-open slab
/// lo <= o < hi, and makes a miss otherwise: a ray lying in the plane where two boxes meet
/// (a scan and its axial pad, axial_pad.hpp) belongs to the upper one only, as a ray in a face
/// between two voxels takes the voxel on its [i, i+1) side. A zero direction is a point, not a
/// ray, and a non-finite origin or direction is no ray at all: both miss.
inline bool clip_to_box(const IndexRay& ray, const glm::dvec3& lo, const glm::dvec3& hi,
                        double s_min, double& s_enter, double& s_exit) {
  s_enter = s_min;
  s_exit = std::numeric_limits<double>::infinity();
  if (ray.direction == glm::dvec3(0.0)) return false;
  for (int a = 0; a < 3; ++a)
    if (!std::isfinite(ray.origin[a]) || !std::isfinite(ray.direction[a])) return false;
  for (int a = 0; a < 3; ++a) {
    const double o = ray.origin[a], d = ray.direction[a];
    if (d == 0.0) {
      if (!(o >= lo[a] && o < hi[a])) return false;
      continue;
    }
    double s0 = (lo[a] - o) / d, s1 = (hi[a] - o) / d;
    if (s0 > s1) std::swap(s0, s1);
    s_enter = std::max(s_enter, s0);
    s_exit = std::min(s_exit, s1);
  }
  return s_exit > s_enter;
}

/// Precomputed per-camera ray generation (avoids inverting K per pixel): world ray through
/// pixel (u, v), same result as Camera::ray.
class RayGenerator {
 public:
  explicit RayGenerator(const Camerad& camera) : orthographic_(camera.is_orthographic()) {
    const Eigen::Matrix3d Rt = camera.R().transpose();
    const Eigen::Matrix3d M = Rt * camera.K().inverse();  // world direction (or offset) per (u,v,1)
    du_ = M.col(0);
    dv_ = M.col(1);
    base_ = M.col(2);
    if (orthographic_) {
      // origin = R^T ((x, y, 0) - t) with (x, y) = Kinv (u, v, 1) restricted to 2D.
      const Eigen::Matrix3d Kinv = camera.K().inverse();
      du_ = Rt.leftCols<2>() * Kinv.block<2, 1>(0, 0);
      dv_ = Rt.leftCols<2>() * Kinv.block<2, 1>(0, 1);
      base_ = Rt.leftCols<2>() * Kinv.block<2, 1>(0, 2) - Rt * camera.t();
      direction_ = camera.principal_axis();
    } else {
      origin_ = camera.center();
    }
  }
  Ray<double> operator()(double u, double v) const {
    if (orthographic_) return {base_ + u * du_ + v * dv_, direction_};
    return {origin_, (base_ + u * du_ + v * dv_).normalized()};
  }

 private:
  bool orthographic_;
  Eigen::Vector3d du_, dv_, base_;
  Eigen::Vector3d origin_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d direction_ = Eigen::Vector3d::Zero();
};

}  // namespace gimm
