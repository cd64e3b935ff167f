#pragma once
/// Closed triangle meshes of vessel masks, in world millimetres.
///
/// mesh_from_mask smooths the binary mask with a small Gaussian (so the iso-surface sits between
/// voxel centres with sub-voxel detail instead of a staircase, but never crosses one: every mask
/// voxel centre stays inside, every other centre outside), pads it with a zero border (so
/// the surface closes at the grid boundary), and extracts the 0.5 iso-surface by marching
/// tetrahedra: each cube is cut into the six tetrahedra of the Kuhn triangulation around its
/// main diagonal. We use tetrahedra rather than the 256-case marching-cubes table because the
/// tetrahedral cases have no ambiguity, so the surface is always a closed 2-manifold where the
/// field is generic, and the split is translation-invariant, so neighbouring cubes agree on
/// their shared faces. Vertices are shared through their grid edge, triangles face outward
/// (towards lower field values).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/core/volume.hpp"

namespace gimm {

struct TriangleMesh {
  std::vector<Eigen::Vector3f> vertices;                ///< world mm
  std::vector<std::array<std::uint32_t, 3>> triangles;  ///< counter-clockwise seen from outside

  /// Enclosed volume (mm^3) by the divergence theorem; positive for outward-facing triangles.
  double enclosed_volume() const {
    double sum = 0;
    for (const auto& t : triangles) {
      const Eigen::Vector3d a = vertices[t[0]].cast<double>(), b = vertices[t[1]].cast<double>(),
                            c = vertices[t[2]].cast<double>();
      sum += a.dot(b.cross(c));
    }
    return sum / 6.0;
  }

  /// True when every edge is shared by exactly two triangles that traverse it in opposite
  /// directions (a closed, consistently oriented surface).
  bool is_closed() const {
    std::unordered_map<std::uint64_t, int> directed;
    for (const auto& t : triangles)
      for (int e = 0; e < 3; ++e) {
        const std::uint64_t key = (std::uint64_t(t[e]) << 32) | t[(e + 1) % 3];
        if (++directed[key] > 1) return false;
      }
    for (const auto& [key, count] : directed) {
      const std::uint64_t reverse = (key << 32) | (key >> 32);
      if (directed.find(reverse) == directed.end()) return false;
    }
    return true;
  }
};

namespace detail {

/// Separable Gaussian blur (sigma in voxels, kernel radius ceil(3 sigma)) of a dense grid
/// (nx, ny, nz), zero outside. Returns the normalised kernel's centre weight (1: no blur).
inline double gaussian_blur(std::vector<float>& g, int nx, int ny, int nz, double sigma) {
  if (sigma <= 0) return 1.0;
  const int radius = static_cast<int>(std::ceil(3 * sigma));
  std::vector<double> kernel(2 * radius + 1);
  double total = 0;
  for (int r = -radius; r <= radius; ++r)
    total += kernel[r + radius] = std::exp(-r * r / (2 * sigma * sigma));
  for (auto& w : kernel) w /= total;
  const std::int64_t stride[3] = {1, nx, static_cast<std::int64_t>(nx) * ny};
  const int n[3] = {nx, ny, nz};
  std::vector<float> tmp(g.size());
  for (int axis = 0; axis < 3; ++axis) {
    for (int k = 0; k < nz; ++k)
      for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i) {
          const int pos[3] = {i, j, k};
          const std::int64_t centre = i + stride[1] * j + stride[2] * k;
          double sum = 0;
          for (int r = -radius; r <= radius; ++r) {
            const int p = pos[axis] + r;
            if (p < 0 || p >= n[axis]) continue;
            sum += kernel[r + radius] * g[static_cast<std::size_t>(centre + r * stride[axis])];
          }
          tmp[static_cast<std::size_t>(centre)] = static_cast<float>(sum);
        }
    g.swap(tmp);
  }
  return kernel[radius];
}

/// Whether voxel v reaches the voxel at v + (the steps of `axes`, a bit set) through voxels of
/// `mask`, one axis at a time (a face-connected path inside the box the two span).
inline bool face_path(const std::vector<std::uint8_t>& mask, std::int64_t v,
                      const std::int64_t step[3], int axes) {
  if (axes == 0) return true;
  for (int a = 0; a < 3; ++a)
    if ((axes >> a & 1) && mask[static_cast<std::size_t>(v + step[a])] &&
        face_path(mask, v + step[a], step, axes & ~(1 << a)))
      return true;
  return false;
}

/// The voxels a mesh of `inside` (a dense 0/1 grid, zero border) must enclose so that its
/// surface keeps the mask's 26-connectivity and has no hollows. The tetrahedra cut each cube
/// along one diagonal, so they join a voxel to 14 of its 26 neighbours: two mask voxels that
/// touch only along an edge or a corner get the voxels between them (a one-voxel staircase
/// would otherwise fall apart into beads). Background enclosed by the mask (not 6-connected to
/// the border) is filled, or it would become a second surface inside the vessel.
inline void close_for_meshing(std::vector<std::uint8_t>& inside, int nx, int ny, int nz) {
  const std::int64_t sy = nx, sz = static_cast<std::int64_t>(nx) * ny;
  const std::vector<std::uint8_t> mask = inside;
  const auto at = [&](int i, int j, int k) { return i + sy * j + sz * k; };
  for (int k = 1; k + 1 < nz; ++k)
    for (int j = 1; j + 1 < ny; ++j)
      for (int i = 1; i + 1 < nx; ++i) {
        const std::int64_t v = at(i, j, k);
        if (!mask[static_cast<std::size_t>(v)]) continue;
        for (int c = 0; c < 27; ++c) {  // the 20 edge and corner neighbours
          const int d[3] = {c % 3 - 1, (c / 3) % 3 - 1, c / 9 - 1};
          const std::int64_t step[3] = {d[0], d[1] * sy, d[2] * sz};
          const int axes = (d[0] != 0) | (d[1] != 0) << 1 | (d[2] != 0) << 2;
          if (axes == 1 || axes == 2 || axes == 4 || axes == 0) continue;  // itself, faces
          if (!mask[static_cast<std::size_t>(v + step[0] + step[1] + step[2])] ||
              face_path(mask, v, step, axes))
            continue;
          for (int sub = 0; sub < 8; ++sub)  // every voxel of the box they span
            if ((sub & axes) == sub)
              inside[static_cast<std::size_t>(v + ((sub & 1) ? step[0] : 0) +
                                              ((sub & 2) ? step[1] : 0) +
                                              ((sub & 4) ? step[2] : 0))] = 1;
        }
      }
  // Flood the background from the border (6-connected); what it does not reach is enclosed.
  // Sweeps forward and backward until nothing changes (a vessel box is mostly background, so a
  // few sweeps do; no queue the size of the box).
  std::vector<std::uint8_t> outside(inside.size(), 0);
  const auto reach = [&](int i, int j, int k, int step) {
    const std::int64_t v = at(i, j, k);
    const auto u = static_cast<std::size_t>(v);
    if (inside[u] || outside[u]) return false;
    const bool border = i == 0 || j == 0 || k == 0 || i == nx - 1 || j == ny - 1 || k == nz - 1;
    if (!border && !outside[static_cast<std::size_t>(v - step)] &&
        !outside[static_cast<std::size_t>(v - step * sy)] &&
        !outside[static_cast<std::size_t>(v - step * sz)])
      return false;
    outside[u] = 1;
    return true;
  };
  for (bool changed = true; changed;) {
    changed = false;
    for (int k = 0; k < nz; ++k)
      for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i) changed |= reach(i, j, k, 1);
    for (int k = nz - 1; k >= 0; --k)
      for (int j = ny - 1; j >= 0; --j)
        for (int i = nx - 1; i >= 0; --i) changed |= reach(i, j, k, -1);
  }
  for (std::size_t v = 0; v < inside.size(); ++v) inside[v] = !outside[v];
}

}  // namespace detail

struct MeshOptions {
  double smoothing_sigma_voxels = 0.7;  ///< 0: no smoothing (iso-surface of the raw mask)
  /// Every mask voxel centre ends up inside the surface, every other outside, except the voxels
  /// close_for_meshing adds (between diagonal neighbours, enclosed holes), which are inside.
  /// 0.45, not 0.5: the blur pulls the 0.5 level of a tube inwards (by about sigma^2 / 2r), and
  /// coronaries are tubes a few voxels wide. Measured on the ImageCAS-size phantom: mesh volume
  /// 0.92-0.93 of the voxel count at 0.5, 0.986-0.989 at 0.45 (the voxel count is within 0.5% of
  /// the analytic tubes there); docs/performance.md.
  double iso = 0.45;
};

/// The vessel surface of `mask` (nonzero = vessel) as a closed mesh in world mm. An empty
/// mask gives an empty mesh.
template <class T>
TriangleMesh mesh_from_mask(const Volume<T>& mask, const MeshOptions& options = {}) {
  GIMM_CHECK(std::isfinite(options.smoothing_sigma_voxels) && options.smoothing_sigma_voxels >= 0 &&
                 options.smoothing_sigma_voxels <= 5,
             "mesh_from_mask: smoothing sigma must be in [0, 5] voxels, got "
                 << options.smoothing_sigma_voxels);
  GIMM_CHECK(options.iso >= 1e-3 && options.iso <= 1 - 1e-3,
             "mesh_from_mask: iso must be in [0.001, 0.999], got " << options.iso);
  // Bounding box of the mask.
  int lo[3] = {mask.nx(), mask.ny(), mask.nz()}, hi[3] = {-1, -1, -1};
  for (int k = 0; k < mask.nz(); ++k)
    for (int j = 0; j < mask.ny(); ++j)
      for (int i = 0; i < mask.nx(); ++i)
        if (mask(i, j, k) != T(0)) {
          const int p[3] = {i, j, k};
          for (int a = 0; a < 3; ++a) {
            lo[a] = std::min(lo[a], p[a]);
            hi[a] = std::max(hi[a], p[a]);
          }
        }
  TriangleMesh mesh;
  if (hi[0] < 0) return mesh;
  // Padded local grid: margin covers the blur radius plus one zero layer.
  const int margin = static_cast<int>(std::ceil(3 * options.smoothing_sigma_voxels)) + 2;
  int n[3], off[3];
  for (int a = 0; a < 3; ++a) {
    off[a] = lo[a] - margin;
    n[a] = hi[a] - lo[a] + 1 + 2 * margin;
  }
  const std::int64_t sy = n[0], sz = static_cast<std::int64_t>(n[0]) * n[1];
  std::vector<float> g(static_cast<std::size_t>(sz * n[2]), 0.0f);
  for (int k = lo[2]; k <= hi[2]; ++k)
    for (int j = lo[1]; j <= hi[1]; ++j)
      for (int i = lo[0]; i <= hi[0]; ++i)
        if (mask(i, j, k) != T(0))
          g[static_cast<std::size_t>((i - off[0]) + sy * (j - off[1]) + sz * (k - off[2]))] = 1.0f;
  std::vector<std::uint8_t> inside(g.size());
  for (std::size_t v = 0; v < g.size(); ++v) inside[v] = g[v] > 0.5f;
  detail::close_for_meshing(inside, n[0], n[1], n[2]);
  for (std::size_t v = 0; v < g.size(); ++v) g[v] = inside[v];
  // The blur moves the surface between voxel centres but must not carry it across one: a vessel
  // thinner than the blur would fade below the iso level and vanish (on a 1 mm grid most of a
  // coronary tree did). A voxel the blur moved to the wrong side of the iso level gets the value
  // it would have on a flat wall of the mask, 0.5 +- w / 2 (w: the kernel's centre weight), so a
  // one-voxel line becomes a tube of radius ~0.4 voxel; every other voxel keeps its smooth value
  // (raising all of them to that level would bring back the staircase on round vessels).
  const float iso = static_cast<float>(options.iso);
  const double wall =
      0.5 * detail::gaussian_blur(g, n[0], n[1], n[2], options.smoothing_sigma_voxels);
  const auto inner = static_cast<float>(std::max(0.5 + wall, (options.iso + 1) / 2));
  const auto outer = static_cast<float>(std::min(0.5 - wall, options.iso / 2));
  for (std::size_t v = 0; v < g.size(); ++v) {
    if (inside[v] && !(g[v] > iso)) g[v] = inner;
    if (!inside[v] && g[v] > iso) g[v] = outer;
  }

  auto gid = [&](int i, int j, int k) { return i + sy * j + sz * k; };
  std::unordered_map<std::uint64_t, std::uint32_t> edge_vertex;
  auto vertex_on_edge = [&](std::int64_t a, std::int64_t b) -> std::uint32_t {
    if (a > b) std::swap(a, b);
    const std::uint64_t key =
        static_cast<std::uint64_t>(a) * static_cast<std::uint64_t>(sz * n[2]) +
        static_cast<std::uint64_t>(b);
    const auto it = edge_vertex.find(key);
    if (it != edge_vertex.end()) return it->second;
    const auto pos = [&](std::int64_t id) {
      return Eigen::Vector3d(static_cast<double>(id % sy), static_cast<double>((id / sy) % n[1]),
                             static_cast<double>(id / sz));
    };
    const double va = g[static_cast<std::size_t>(a)], vb = g[static_cast<std::size_t>(b)];
    const double t = (iso - va) / (vb - va);
    const Eigen::Vector3d local = pos(a) + t * (pos(b) - pos(a));
    const Eigen::Vector3d ijk = local + Eigen::Vector3d(off[0], off[1], off[2]);
    const auto id = static_cast<std::uint32_t>(mesh.vertices.size());
    mesh.vertices.push_back(mask.index_to_world(ijk).template cast<float>());
    edge_vertex.emplace(key, id);
    return id;
  };
  auto emit = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c,
                  const Eigen::Vector3d& outward) {
    const Eigen::Vector3f n_f =
        (mesh.vertices[b] - mesh.vertices[a]).cross(mesh.vertices[c] - mesh.vertices[a]);
    if (n_f.cast<double>().dot(outward) < 0) std::swap(b, c);
    mesh.triangles.push_back({a, b, c});
  };
  // Kuhn triangulation: corner c = dx + 2 dy + 4 dz; six tetrahedra around the 0-7 diagonal.
  static const int kTets[6][4] = {{0, 1, 3, 7}, {0, 1, 5, 7}, {0, 2, 3, 7},
                                  {0, 2, 6, 7}, {0, 4, 5, 7}, {0, 4, 6, 7}};
  const Eigen::Matrix3d A = mask.geometry().index_to_world_matrix();
  for (int k = 0; k + 1 < n[2]; ++k)
    for (int j = 0; j + 1 < n[1]; ++j)
      for (int i = 0; i + 1 < n[0]; ++i) {
        std::int64_t corner[8];
        bool any_in = false, any_out = false;
        for (int c = 0; c < 8; ++c) {
          corner[c] = gid(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1));
          (g[static_cast<std::size_t>(corner[c])] > iso ? any_in : any_out) = true;
        }
        if (!any_in || !any_out) continue;
        for (const auto& tet : kTets) {
          std::int64_t in[4], out[4];
          int n_in = 0, n_out = 0;
          for (int v = 0; v < 4; ++v) {
            const std::int64_t id = corner[tet[v]];
            if (g[static_cast<std::size_t>(id)] > iso)
              in[n_in++] = id;
            else
              out[n_out++] = id;
          }
          if (n_in == 0 || n_out == 0) continue;
          // Outward reference direction (world): from the inside corners to the outside ones.
          auto local = [&](std::int64_t id) {
            return Eigen::Vector3d(static_cast<double>(id % sy),
                                   static_cast<double>((id / sy) % n[1]),
                                   static_cast<double>(id / sz));
          };
          Eigen::Vector3d c_in = Eigen::Vector3d::Zero(), c_out = Eigen::Vector3d::Zero();
          for (int v = 0; v < n_in; ++v) c_in += local(in[v]) / n_in;
          for (int v = 0; v < n_out; ++v) c_out += local(out[v]) / n_out;
          const Eigen::Vector3d outward = A * (c_out - c_in);
          if (n_in == 1 || n_out == 1) {
            const std::int64_t lone = n_in == 1 ? in[0] : out[0];
            const std::int64_t* others = n_in == 1 ? out : in;
            emit(vertex_on_edge(lone, others[0]), vertex_on_edge(lone, others[1]),
                 vertex_on_edge(lone, others[2]), outward);
          } else {  // 2 in, 2 out: a quad in0-out0, in0-out1, in1-out1, in1-out0
            const std::uint32_t q0 = vertex_on_edge(in[0], out[0]),
                                q1 = vertex_on_edge(in[0], out[1]),
                                q2 = vertex_on_edge(in[1], out[1]),
                                q3 = vertex_on_edge(in[1], out[0]);
            emit(q0, q1, q2, outward);
            emit(q0, q2, q3, outward);
          }
        }
      }
  return mesh;
}

}  // namespace gimm
