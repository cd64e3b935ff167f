#pragma once
/// A vessel surface that a renderer composites into its views: per pixel the chord through the
/// vessels, the depth of the first hit and the overlap count, and a visibility test per point.
/// The Embree mesh projector (vessel_mesh_projector.hpp, target gimm::embree) is the one in gimm;
/// the interface keeps the renderer free of Embree for users who render voxel vessels only.
#include <Eigen/Core>
#include <cstdint>

#include "gimm/core/image.hpp"
#include "gimm/geometry/camera.hpp"

namespace gimm {

struct VesselProjection {
  Image<float> chord_mm;         ///< (rows, cols) chord length through the vessels, mm
  Image<float> first_hit_mm;     ///< (rows, cols) distance from the source to the first hit, mm
  Image<std::uint8_t> passages;  ///< (rows, cols) number of vessel passages (overlap count)
};

class VesselSurface {
 public:
  virtual ~VesselSurface() = default;
  /// Every detector pixel of `camera` (rays through pixel centres).
  virtual VesselProjection project(const Camerad& camera) const = 0;
  /// Whether world point X (on a vessel's centreline) is seen by `camera` without another
  /// vessel passage in front of it: at most one passage (its own) between the source and X.
  virtual bool unoccluded(const Camerad& camera, const Eigen::Vector3d& X) const = 0;
};

}  // namespace gimm
