#pragma once
/// Connected components of a binary label (26-connectivity) and the LCA/RCA split.
///
/// split_coronary_systems: drops components smaller than `min_voxels` (specks), takes the two
/// largest remaining ones and calls the one whose centroid lies further to the patient's left
/// (larger world x in LPS) the LCA, the other the RCA.
/// Documented choices for awkward labels:
///   - values other than 0 and 1 -> gimm::Error naming the value (ImageCAS labels are 0/1);
///   - no component -> gimm::Error ("empty coronary mask");
///   - exactly one component -> gimm::Error unless `allow_single` is set, in which case it is
///     assigned by its centroid relative to `heart_center_x` (default: the volume centre)
///     and the other system is empty (its mask all 0, its voxel count 0).
/// What is left out is counted (`dropped_voxels`, `components`, `label_voxels`), so a caller
/// can tell a clean two-tree label from one that lost a third of its vessels.
#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cstdint>
#include <numeric>
#include <optional>
#include <string>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/core/volume.hpp"

namespace gimm {

struct Components {
  Volume<std::int32_t> labels;      ///< 0 = background, 1..count = component id
  std::vector<std::int64_t> sizes;  ///< sizes[id - 1] = voxel count of component id
  int count() const { return static_cast<int>(sizes.size()); }
};

/// 26-connected components of the voxels where mask != 0 (iterative flood fill, no recursion).
template <class T>
Components connected_components(const Volume<T>& mask) {
  Components out{Volume<std::int32_t>(mask.geometry(), 0), {}};
  const int nx = mask.nx(), ny = mask.ny(), nz = mask.nz();
  std::vector<std::array<int, 3>> stack;
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        if (mask(i, j, k) == T(0) || out.labels(i, j, k) != 0) continue;
        const auto id = static_cast<std::int32_t>(out.sizes.size() + 1);
        std::int64_t size = 0;
        stack.push_back({i, j, k});
        out.labels(i, j, k) = id;
        while (!stack.empty()) {
          const auto [ci, cj, ck] = stack.back();
          stack.pop_back();
          ++size;
          for (int dk = -1; dk <= 1; ++dk)
            for (int dj = -1; dj <= 1; ++dj)
              for (int di = -1; di <= 1; ++di) {
                const int x = ci + di, y = cj + dj, z = ck + dk;
                if (!mask.contains(x, y, z) || mask(x, y, z) == T(0) || out.labels(x, y, z) != 0)
                  continue;
                out.labels(x, y, z) = id;
                stack.push_back({x, y, z});
              }
        }
        out.sizes.push_back(size);
      }
  return out;
}

struct CoronarySplit {
  Volume<std::uint8_t> lca;  ///< 1 inside the left coronary tree
  Volume<std::uint8_t> rca;  ///< 1 inside the right coronary tree
  std::int64_t lca_voxels = 0;
  std::int64_t rca_voxels = 0;
  std::int64_t dropped_voxels = 0;  ///< voxels in specks and in components beyond the two largest
  std::int64_t label_voxels = 0;    ///< every non-zero voxel of the label
  int components = 0;               ///< 26-connected components of the label, specks included

  /// The share of the label's voxels in neither system (0 for an empty label).
  double dropped_fraction() const {
    return label_voxels ? static_cast<double>(dropped_voxels) / static_cast<double>(label_voxels)
                        : 0.0;
  }
};

struct SplitOptions {
  std::int64_t min_voxels = 20;  ///< components smaller than this are specks
  bool allow_single = false;
  std::optional<double> heart_center_x;  ///< world x (LPS mm) splitting left from right
};

template <class T>
CoronarySplit split_coronary_systems(const Volume<T>& label, const SplitOptions& options = {},
                                     const std::string& name = "label") {
  for (const T v : label)
    GIMM_CHECK(v == T(0) || v == T(1),
               name << ": coronary label must hold only 0 and 1, found " << +v);
  const Components comps = connected_components(label);
  std::vector<int> ids;
  for (int id = 1; id <= comps.count(); ++id)
    if (comps.sizes[static_cast<std::size_t>(id - 1)] >= options.min_voxels) ids.push_back(id);
  std::stable_sort(ids.begin(), ids.end(), [&](int a, int b) {
    return comps.sizes[static_cast<std::size_t>(a - 1)] >
           comps.sizes[static_cast<std::size_t>(b - 1)];
  });
  GIMM_CHECK(!ids.empty(), name << ": empty coronary mask (no component of at least "
                                << options.min_voxels << " voxels)");
  GIMM_CHECK(ids.size() >= 2 || options.allow_single,
             name << ": only one coronary component of at least " << options.min_voxels
                  << " voxels; LCA/RCA cannot be split (to accept it as a single system, set "
                     "SplitOptions::allow_single)");

  // Centroid x (world) of each candidate.
  auto centroid_x = [&](int id) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    std::int64_t n = 0;
    for (int k = 0; k < label.nz(); ++k)
      for (int j = 0; j < label.ny(); ++j)
        for (int i = 0; i < label.nx(); ++i)
          if (comps.labels(i, j, k) == id) {
            sum += Eigen::Vector3d(i, j, k);
            ++n;
          }
    return label.index_to_world(sum / static_cast<double>(n)).x();
  };

  CoronarySplit out{Volume<std::uint8_t>(label.geometry(), 0),
                    Volume<std::uint8_t>(label.geometry(), 0)};
  int lca_id = 0, rca_id = 0;
  if (ids.size() >= 2) {
    const double x0 = centroid_x(ids[0]), x1 = centroid_x(ids[1]);
    lca_id = x0 >= x1 ? ids[0] : ids[1];  // LPS: +x is the patient's left
    rca_id = x0 >= x1 ? ids[1] : ids[0];
  } else {
    const double centre = options.heart_center_x.value_or(
        label
            .index_to_world(Eigen::Vector3d((label.nx() - 1) / 2.0, (label.ny() - 1) / 2.0,
                                            (label.nz() - 1) / 2.0))
            .x());
    (centroid_x(ids[0]) >= centre ? lca_id : rca_id) = ids[0];
  }
  std::int64_t total = 0;
  for (std::size_t v = 0; v < label.size(); ++v) {
    const std::int32_t id = comps.labels.storage()[v];
    if (id == 0) continue;
    ++total;
    if (id == lca_id) {
      out.lca.storage()[v] = 1;
      ++out.lca_voxels;
    } else if (id == rca_id) {
      out.rca.storage()[v] = 1;
      ++out.rca_voxels;
    }
  }
  out.label_voxels = total;
  out.components = comps.count();
  out.dropped_voxels = total - out.lca_voxels - out.rca_voxels;
  return out;
}

}  // namespace gimm
