#pragma once
/// 3D centerlines from a binary vessel mask: distance transform, topology-preserving thinning,
/// a branch graph, spur pruning, and a CenterlineTree in world mm.
///
/// Thinning: sequential directional thinning (six sub-iterations, one per face direction).
/// A border voxel is deleted when it is a simple point (Bertrand & Malandain: its 26-neighbour
/// foreground is one 26-connected component, and the background in its 18-neighbourhood has
/// exactly one 6-component 6-adjacent to it) and is not a curve end (more than one neighbour).
/// Candidates are re-checked at deletion time against the current image, so topology is kept
/// exactly; they are visited in order of increasing distance to the background, so the
/// surviving curve runs along the medial axis. This is the same family as Lee et al. (1994),
/// which the reference (skimage skeletonize_3d) uses; we re-derive simplicity by local
/// connected components instead of Lee's Euler lookup table, which is shorter to verify.
///
/// Radius: the exact Euclidean distance transform (Felzenszwalb & Huttenlocher, separable,
/// anisotropic spacing) of the mask, i.e. distance from a voxel centre to the nearest
/// background voxel centre, minus half a voxel to approximate the distance to the boundary.
#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <queue>
#include <vector>

#include "gimm/anatomy/centerlines.hpp"
#include "gimm/core/distance_transform.hpp"
#include "gimm/core/volume.hpp"

namespace gimm {

namespace detail {

/// Neighbourhood offsets: index c = (dx+1) + 3(dy+1) + 9(dz+1), centre 13.
inline const std::array<std::array<int, 3>, 27>& cube_offsets() {
  static const auto table = [] {
    std::array<std::array<int, 3>, 27> t{};
    for (int c = 0; c < 27; ++c) t[c] = {c % 3 - 1, (c / 3) % 3 - 1, c / 9 - 1};
    return t;
  }();
  return table;
}

inline int cube_distance_class(int c) {  // 1 = face, 2 = edge, 3 = corner neighbour
  const auto& o = cube_offsets()[c];
  return std::abs(o[0]) + std::abs(o[1]) + std::abs(o[2]);
}

/// Whether neighbourhood cells a and b are adjacent: one step apart on every axis at most, and
/// at most `max_class` axes differing (1: 6-adjacency, 3: 26-adjacency).
inline bool cube_adjacent(int a, int b, int max_class) {
  const auto& off = cube_offsets();
  int dist = 0, cheb = 0;
  for (int k = 0; k < 3; ++k) {
    const int dd = std::abs(off[a][k] - off[b][k]);
    dist += dd;
    cheb = std::max(cheb, dd);
  }
  return cheb == 1 && dist <= max_class;
}

/// Connected components (under `max_class` adjacency) of the cells in `set` that contain a
/// cell of `seeds`; counting stops at 2, which is all the simple-point test needs.
inline int cube_components_upto2(std::uint32_t set, std::uint32_t seeds, int max_class) {
  int components = 0;
  std::uint32_t seen = 0;
  for (int s = 0; s < 27; ++s) {
    if (!(set & seeds & (1u << s)) || (seen >> s & 1)) continue;
    if (++components > 1) return components;
    int stack[27], top = 0;
    stack[top++] = s;
    seen |= 1u << s;
    while (top) {
      const int a = stack[--top];
      for (int b = 0; b < 27; ++b)
        if ((set >> b & 1) && !(seen >> b & 1) && cube_adjacent(a, b, max_class)) {
          seen |= 1u << b;
          stack[top++] = b;
        }
    }
  }
  return components;
}

/// Simple-point test on a 3x3x3 neighbourhood (bit c set = foreground; centre ignored).
inline bool is_simple(std::uint32_t cube) {
  cube &= ~(1u << 13);
  // 1. Foreground in N26: exactly one 26-connected component.
  if (cube_components_upto2(cube, 0x7ffffff, 3) != 1) return false;
  // 2. Background in N18: exactly one 6-component containing a face neighbour of the centre.
  std::uint32_t background = 0, faces = 0;
  for (int c = 0; c < 27; ++c) {
    if (c != 13 && cube_distance_class(c) <= 2 && !(cube >> c & 1)) background |= 1u << c;
    if (cube_distance_class(c) == 1) faces |= 1u << c;
  }
  return cube_components_upto2(background, faces, 1) == 1;
}

}  // namespace detail

/// Thins `mask` (nonzero = foreground) to 26-connected curves, keeping its topology.
template <class T>
Volume<std::uint8_t> thin(const Volume<T>& mask, const Volume<float>& distance) {
  Volume<std::uint8_t> img(mask.geometry(), 0);
  for (std::size_t i = 0; i < mask.size(); ++i) img.data()[i] = mask.data()[i] != T(0);
  const auto& off = detail::cube_offsets();
  auto cube_at = [&](int i, int j, int k) {
    std::uint32_t cube = 0;
    for (int c = 0; c < 27; ++c) {
      const int x = i + off[c][0], y = j + off[c][1], z = k + off[c][2];
      if (img.contains(x, y, z) && img(x, y, z)) cube |= 1u << c;
    }
    return cube;
  };
  static const int faces[6] = {4, 22, 10, 16, 12, 14};  // -z, +z, -y, +y, -x, +x
  struct Candidate {
    float distance;
    int i, j, k;
  };
  std::vector<std::array<int, 3>> foreground;
  for (int k = 0; k < img.nz(); ++k)
    for (int j = 0; j < img.ny(); ++j)
      for (int i = 0; i < img.nx(); ++i)
        if (img(i, j, k)) foreground.push_back({i, j, k});
  bool changed = true;
  while (changed) {
    changed = false;
    for (const int face : faces) {
      std::vector<Candidate> border;
      for (const auto& [i, j, k] : foreground) {
        if (!img(i, j, k)) continue;
        const int x = i + off[face][0], y = j + off[face][1], z = k + off[face][2];
        if (img.contains(x, y, z) && img(x, y, z)) continue;  // not a border in this direction
        border.push_back({distance(i, j, k), i, j, k});
      }
      std::stable_sort(border.begin(), border.end(), [](const Candidate& a, const Candidate& b) {
        return a.distance < b.distance;
      });
      for (const auto& c : border) {
        const std::uint32_t cube = cube_at(c.i, c.j, c.k);
        const int neighbours = __builtin_popcount(cube & ~(1u << 13));
        if (neighbours <= 1) continue;  // a curve end: keep it
        if (!detail::is_simple(cube)) continue;
        img(c.i, c.j, c.k) = 0;
        changed = true;
      }
    }
    foreground.erase(std::remove_if(foreground.begin(), foreground.end(),
                                    [&](const auto& v) { return !img(v[0], v[1], v[2]); }),
                     foreground.end());
  }
  return img;
}

struct SkeletonOptions {
  double min_spur_mm = 3.0;         ///< spurs shorter than max(this, spur_radius_factor * r) go
  double spur_radius_factor = 2.5;  ///< r = radius at the junction the spur leaves from
  CoronarySystem system = CoronarySystem::LCA;
};

namespace detail {

struct SkeletonGraph {
  std::vector<std::array<int, 3>> voxels;
  std::vector<std::vector<int>> neighbours;
};

inline SkeletonGraph skeleton_graph(const Volume<std::uint8_t>& skel) {
  SkeletonGraph g;
  std::map<std::size_t, int> id;
  for (int k = 0; k < skel.nz(); ++k)
    for (int j = 0; j < skel.ny(); ++j)
      for (int i = 0; i < skel.nx(); ++i)
        if (skel(i, j, k)) {
          id[skel.linear_index(i, j, k)] = static_cast<int>(g.voxels.size());
          g.voxels.push_back({i, j, k});
        }
  g.neighbours.resize(g.voxels.size());
  const auto& off = cube_offsets();
  for (std::size_t v = 0; v < g.voxels.size(); ++v)
    for (int c = 0; c < 27; ++c) {
      if (c == 13) continue;
      const int x = g.voxels[v][0] + off[c][0], y = g.voxels[v][1] + off[c][1],
                z = g.voxels[v][2] + off[c][2];
      if (!skel.contains(x, y, z) || !skel(x, y, z)) continue;
      g.neighbours[v].push_back(id[skel.linear_index(x, y, z)]);
    }
  return g;
}

}  // namespace detail

/// Centerlines of one vessel system's mask: thinning, branch graph rooted at the thickest end
/// (the ostium), spurs pruned. Branches run proximal to distal; each child starts at the
/// junction point of its parent. Throws if the mask is empty.
template <class T>
CenterlineTree extract_centerlines(const Volume<T>& full_mask, const SkeletonOptions& options = {},
                                   const std::string& what = "mask") {
  GIMM_CHECK(std::isfinite(options.min_spur_mm) && options.min_spur_mm >= 0,
             what << ": min_spur_mm must be >= 0, got " << options.min_spur_mm);
  GIMM_CHECK(std::isfinite(options.spur_radius_factor) && options.spur_radius_factor >= 0,
             what << ": spur_radius_factor must be >= 0, got " << options.spur_radius_factor);
  const Volume<std::uint8_t> mask = crop_to_foreground(full_mask, 2);
  const Volume<float> distance = distance_to_background(mask);
  Volume<std::uint8_t> skel = thin(mask, distance);
  const double half_voxel = 0.5 * mask.spacing().minCoeff();
  auto radius_of = [&](const std::array<int, 3>& v) {
    return std::max(half_voxel, double(distance(v[0], v[1], v[2])) - half_voxel);
  };
  // Prune spurs until none is left: a spur is a path from an end voxel to a junction voxel.
  for (int round = 0; round < 100; ++round) {
    const detail::SkeletonGraph g = detail::skeleton_graph(skel);
    bool pruned = false;
    for (std::size_t v = 0; v < g.voxels.size(); ++v) {
      if (g.neighbours[v].size() != 1) continue;
      std::vector<int> path{static_cast<int>(v)};
      int prev = -1, cur = static_cast<int>(v);
      double length = 0;
      while (g.neighbours[cur].size() <= 2) {
        int next = -1;
        for (int n : g.neighbours[cur])
          if (n != prev && std::find(path.begin(), path.end(), n) == path.end()) next = n;
        if (next < 0) break;
        Eigen::Vector3d step;
        for (int a = 0; a < 3; ++a)
          step[a] = (g.voxels[next][a] - g.voxels[cur][a]) * mask.spacing()[a];
        length += step.norm();
        prev = cur;
        cur = next;
        path.push_back(cur);
      }
      if (g.neighbours[cur].size() < 3) continue;  // reached another end: an isolated curve
      const double limit =
          std::max(options.min_spur_mm, options.spur_radius_factor * radius_of(g.voxels[cur]));
      if (length >= limit) continue;
      path.pop_back();  // keep the junction voxel
      for (int p : path) skel(g.voxels[p][0], g.voxels[p][1], g.voxels[p][2]) = 0;
      pruned = true;
    }
    if (!pruned) break;
  }

  const detail::SkeletonGraph g = detail::skeleton_graph(skel);
  GIMM_CHECK(!g.voxels.empty(), what << ": empty mask, no centerline");
  // Root: the end voxel with the largest radius (the ostium is the thickest end).
  int root = 0;
  double best = -1;
  for (std::size_t v = 0; v < g.voxels.size(); ++v)
    if (g.neighbours[v].size() <= 1 && radius_of(g.voxels[v]) > best) {
      best = radius_of(g.voxels[v]);
      root = static_cast<int>(v);
    }
  // Depth-first walk from the root: a branch ends at a junction (degree >= 3) or an end, and
  // every other neighbour of a junction starts a child branch there.
  CenterlineTree tree;
  std::vector<char> visited(g.voxels.size(), 0);
  struct Start {
    int from, first, parent;
  };
  std::vector<Start> todo{{-1, root, -1}};
  auto world = [&](int v) {
    return mask.index_to_world(Eigen::Vector3d(g.voxels[v][0], g.voxels[v][1], g.voxels[v][2]));
  };
  while (!todo.empty()) {
    const Start s = todo.back();
    todo.pop_back();
    if (visited[s.first]) continue;
    CenterlineBranch br;
    br.system = options.system;
    br.parent = s.parent;
    if (s.from >= 0) {
      br.points.push_back(world(s.from));
      br.radii.push_back(radius_of(g.voxels[s.from]));
    }
    int cur = s.first;
    while (true) {
      visited[cur] = 1;
      br.points.push_back(world(cur));
      br.radii.push_back(radius_of(g.voxels[cur]));
      std::vector<int> open;
      for (int n : g.neighbours[cur])
        if (!visited[n]) open.push_back(n);
      // Junction clusters: mark all unvisited neighbours now so siblings do not walk back.
      if (open.size() == 1 && g.neighbours[cur].size() <= 2) {
        cur = open.front();
        continue;
      }
      const int index = static_cast<int>(tree.branches.size());
      for (int n : open) todo.push_back({cur, n, index});
      break;
    }
    if (br.points.size() >= 2) {
      br.name = to_string(options.system) + std::string("-") + std::to_string(tree.branches.size());
      tree.branches.push_back(std::move(br));
    } else {
      // A single-voxel piece between two junction voxels: hand its children to the parent.
      for (auto& t : todo)
        if (t.parent == static_cast<int>(tree.branches.size())) t.parent = s.parent;
    }
  }
  tree.validate(what);
  return tree;
}

/// Agreement of an extracted tree with a ground-truth tree (both world mm).
struct CenterlineComparison {
  double mean_distance_mm = 0;        ///< extracted points to the nearest truth point, mean
  double mean_truth_distance_mm = 0;  ///< truth points to the nearest extracted point, mean
  double spurious_length_mm = 0;      ///< extracted length farther than `tolerance` from the truth
  double missed_length_mm = 0;        ///< truth length farther than `tolerance` from the extraction
  double extracted_length_mm = 0;
  double truth_length_mm = 0;
};

inline CenterlineComparison compare_centerlines(const CenterlineTree& extracted,
                                                const CenterlineTree& truth, double tolerance_mm) {
  auto nearest = [](const Eigen::Vector3d& p, const CenterlineTree& t) {
    double d = std::numeric_limits<double>::infinity();
    for (const auto& b : t.branches)
      for (const auto& q : b.points) d = std::min(d, (p - q).squaredNorm());
    return std::sqrt(d);
  };
  auto one_way = [&](const CenterlineTree& from, const CenterlineTree& to, double& mean,
                     double& far_length, double& total) {
    double sum = 0;
    std::size_t count = 0;
    for (const auto& b : from.branches)
      for (std::size_t n = 0; n < b.points.size(); ++n) {
        const double d = nearest(b.points[n], to);
        sum += d;
        ++count;
        if (n == 0) continue;
        const double seg = (b.points[n] - b.points[n - 1]).norm();
        total += seg;
        if (d > tolerance_mm) far_length += seg;
      }
    mean = count ? sum / count : 0;
  };
  CenterlineComparison c;
  one_way(extracted, truth, c.mean_distance_mm, c.spurious_length_mm, c.extracted_length_mm);
  one_way(truth, extracted, c.mean_truth_distance_mm, c.missed_length_mm, c.truth_length_mm);
  return c;
}

}  // namespace gimm
