#pragma once
/// Where the C-arm is centred: the one isocentre rule of gimm (dataset views and gimm-drr).
///
/// A cardiologist centres the injected coronary tree in the field of view; gimm puts the
/// isocentre at the centroid of the injected system's lumen voxels (world mm, LPS). Without a
/// vessel mask (a plain DRR) it is the centre of the volume's grid: the world origin of an
/// ImageCAS file is nowhere near the heart.
#include <Eigen/Core>
#include <string>

#include "gimm/core/error.hpp"
#include "gimm/core/volume.hpp"

namespace gimm {

/// The centroid of the nonzero voxels of `vessels` (world mm). Throws on an empty mask.
template <class T>
Eigen::Vector3d vessel_isocenter(const Volume<T>& vessels,
                                 const std::string& what = "vessel mask") {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  std::int64_t count = 0;
  for (int k = 0; k < vessels.nz(); ++k)
    for (int j = 0; j < vessels.ny(); ++j)
      for (int i = 0; i < vessels.nx(); ++i)
        if (vessels(i, j, k) != T(0)) {
          sum += Eigen::Vector3d(i, j, k);
          ++count;
        }
  GIMM_CHECK(count > 0, what << ": no vessel voxel to centre the C-arm on (the mask is empty)");
  return vessels.index_to_world(sum / static_cast<double>(count));
}

/// The centre of the grid of `volume` (world mm): the isocentre of a DRR without vessels.
template <class T>
Eigen::Vector3d grid_center(const Volume<T>& volume) {
  return volume.index_to_world(Eigen::Vector3d(volume.nx() - 1, volume.ny() - 1, volume.nz() - 1) /
                               2);
}

}  // namespace gimm
