#pragma once
/// 2D vessel centerlines of an angiogram's vessel mask, as a graph of ordered pixel chains.
///
/// - thin_mask: Zhang & Suen (1984) parallel thinning to a one-pixel-wide, 8-connected skeleton.
/// - centerline_graph: the skeleton's nodes are its end pixels (one neighbour) and its branch
///   pixels (crossing number >= 3: three or more separate runs of skeleton among the 8
///   neighbours; a staircase corner has three neighbours but crossing number 2 and is not a
///   node). Branches are the chains between nodes, traced pixel by pixel (4-neighbours before
///   diagonal ones), plus closed loops; chains shorter than `min_branch_px` pixels are dropped
///   (thinning spurs, the fragments inside a junction).
/// - The radius of a centerline pixel is its distance to the nearest background pixel centre
///   minus half a pixel, as for the 3D centerlines; found by a search around the pixel (only the
///   centerline needs it, a few percent of the image), up to kMaxRadiusPx.
#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/core/image.hpp"

namespace gimm {

struct Branch2d {
  std::vector<Eigen::Vector2d> points;  ///< pixel centres (u, v), ordered along the vessel
  std::vector<double> radius_px;        ///< one per point
};

struct CenterlineGraph2d {
  int rows = 0, cols = 0;
  std::vector<Branch2d> branches;
  std::size_t point_count() const {
    std::size_t n = 0;
    for (const auto& b : branches) n += b.points.size();
    return n;
  }
};

namespace detail {

/// Length of a chain along its points, in pixels.
inline double chain_length_px(const Branch2d& chain) {
  double length = 0;
  for (std::size_t k = 1; k < chain.points.size(); ++k)
    length += (chain.points[k] - chain.points[k - 1]).norm();
  return length;
}

// The 8 neighbours in cyclic order N, NE, E, SE, S, SW, W, NW (row offset, col offset).
constexpr std::array<std::array<int, 2>, 8> kRing = {
    {{-1, 0}, {-1, 1}, {0, 1}, {1, 1}, {1, 0}, {1, -1}, {0, -1}, {-1, -1}}};

inline bool lit(const Image<std::uint8_t>& m, int r, int c) {
  return m.contains(r, c) && m(r, c) != 0;
}

/// Foreground neighbours, and 0 -> 1 transitions around the ring (the crossing number).
inline std::array<int, 2> ring_counts(const Image<std::uint8_t>& m, int r, int c) {
  int count = 0, transitions = 0;
  for (int k = 0; k < 8; ++k) {
    const bool here = lit(m, r + kRing[k][0], c + kRing[k][1]);
    const bool next = lit(m, r + kRing[(k + 1) % 8][0], c + kRing[(k + 1) % 8][1]);
    count += here;
    transitions += !here && next;
  }
  return {count, transitions};
}

/// Ring neighbour k as an offset in a row-major buffer `stride` wide.
constexpr int kRingOffsetOf(int k, int stride) {
  return kRing[k][0] * stride + kRing[k][1];
}

constexpr int kMaxRadiusPx = 32;

/// Distance from (r, c) to the nearest zero pixel of `m` (outside the image counts as zero),
/// searched in growing square rings; kMaxRadiusPx when none is nearer. Squared distances are
/// integers: compared exactly, one square root at the end.
inline double distance_to_zero(const Image<std::uint8_t>& m, int r, int c) {
  int best2 = kMaxRadiusPx * kMaxRadiusPx;
  // Ring `ring` holds distances >= ring, so the search ends once (ring - 1)^2 >= best2.
  for (int ring = 1; ring <= kMaxRadiusPx && (ring - 1) * (ring - 1) < best2; ++ring) {
    const bool inside =
        r - ring >= 0 && c - ring >= 0 && r + ring < m.rows() && c + ring < m.cols();
    for (int dr = -ring; dr <= ring; ++dr)
      for (int dc = -ring; dc <= ring; dc += (std::abs(dr) == ring ? 1 : 2 * ring))
        if (inside ? m(r + dr, c + dc) == 0 : !lit(m, r + dr, c + dc))
          best2 = std::min(best2, dr * dr + dc * dc);
  }
  return std::sqrt(static_cast<double>(best2));
}

}  // namespace detail

namespace detail {

/// Zhang-Suen's deletion rule for each 8-neighbourhood (bit k = ring neighbour k lit), one table
/// per sub-iteration: 2 to 6 neighbours, crossing number 1, and the sub-iteration's N/E/S/W test.
inline const std::array<std::array<bool, 256>, 2>& zhang_suen_table() {
  static const std::array<std::array<bool, 256>, 2> table = [] {
    std::array<std::array<bool, 256>, 2> t{};
    for (int code = 0; code < 256; ++code) {
      const auto bit = [code](int k) { return ((code >> (k % 8)) & 1) != 0; };
      int count = 0, transitions = 0;
      for (int k = 0; k < 8; ++k) {
        count += bit(k);
        transitions += !bit(k) && bit(k + 1);
      }
      const bool n = bit(0), e = bit(2), s = bit(4), w = bit(6);
      const bool shape = count >= 2 && count <= 6 && transitions == 1;
      t[0][code] = shape && !(n && e && s) && !(e && s && w);
      t[1][code] = shape && !(n && e && w) && !(n && s && w);
    }
    return t;
  }();
  return table;
}

}  // namespace detail

/// The working memory of thin_mask() and centerline_graph(), for a caller that keeps it between
/// calls (a matcher, view after view): at one image size it is allocated once.
struct CenterlineBuffers {
  std::vector<std::uint8_t> framed, queued;  // thin_mask's framed copy and its queue marks
  std::array<std::vector<int>, 2> to_check;
  std::vector<int> checking, remove;
  Image<std::uint8_t> skeleton, binary, node, used;
};

/// One-pixel-wide skeleton of a binary mask (nonzero = foreground) into `out`, Zhang-Suen. The mask
/// is copied into a frame one pixel wider (no bounds checks), and each pixel's neighbourhood is
/// looked up in a 256-entry table. A sub-iteration looks only at the pixels whose neighbourhood
/// changed since that sub-iteration last kept them (at first, all): the others would be kept
/// again. Each sub-iteration still removes what the plain rule removes, from the same state.
template <class T>
void thin_mask(const Image<T>& mask, Image<std::uint8_t>& out, CenterlineBuffers& buffers) {
  const int rows = mask.rows(), cols = mask.cols(), stride = cols + 2;
  std::vector<std::uint8_t>& m = buffers.framed;
  m.assign(static_cast<std::size_t>(rows + 2) * stride, 0);
  // to_check[p]: the pixels sub-iteration p has to look at; `queued` bit p marks them.
  std::array<std::vector<int>, 2>& to_check = buffers.to_check;
  to_check[0].clear();
  std::vector<std::uint8_t>& queued = buffers.queued;
  queued.assign(m.size(), 0);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c)
      if (mask(r, c) != T(0)) {
        const int i = (r + 1) * stride + c + 1;
        m[static_cast<std::size_t>(i)] = 1;
        queued[static_cast<std::size_t>(i)] = 3;
        to_check[0].push_back(i);
      }
  to_check[1] = to_check[0];
  std::array<int, 8> offset{};  // kRing as index offsets in the framed buffer
  for (int k = 0; k < 8; ++k) offset[k] = detail::kRingOffsetOf(k, stride);
  const auto& table = detail::zhang_suen_table();
  std::vector<int>&checking = buffers.checking, &remove = buffers.remove;
  for (int pass = 0; !to_check[0].empty() || !to_check[1].empty(); pass = 1 - pass) {
    checking.swap(to_check[pass]);
    to_check[pass].clear();
    remove.clear();
    const auto bit = static_cast<std::uint8_t>(1 << pass);
    for (int i : checking) {
      const auto at = static_cast<std::size_t>(i);
      queued[at] &= static_cast<std::uint8_t>(~bit);
      if (!m[at]) continue;  // removed since it was queued
      int code = 0;
      for (int k = 0; k < 8; ++k) code |= m[static_cast<std::size_t>(i + offset[k])] << k;
      if (table[pass][code]) remove.push_back(i);
    }
    for (int i : remove) m[static_cast<std::size_t>(i)] = 0;
    for (int i : remove)  // their neighbours changed: both sub-iterations look again
      for (int k = 0; k < 8; ++k) {
        const auto j = static_cast<std::size_t>(i + offset[k]);
        if (!m[j]) continue;
        for (int p = 0; p < 2; ++p)
          if (!(queued[j] & (1 << p))) {
            queued[j] |= static_cast<std::uint8_t>(1 << p);
            to_check[p].push_back(static_cast<int>(j));
          }
      }
  }
  out.resize(rows, cols);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c)
      out(r, c) = m[static_cast<std::size_t>((r + 1) * stride + c + 1)];
}

template <class T>
Image<std::uint8_t> thin_mask(const Image<T>& mask) {
  Image<std::uint8_t> out;
  CenterlineBuffers buffers;
  thin_mask(mask, out, buffers);
  return out;
}

/// The centerline graph of a vessel mask (nonzero = vessel), in `buffers`' working memory.
template <class T>
CenterlineGraph2d centerline_graph(const Image<T>& mask, int min_branch_px,
                                   CenterlineBuffers& buffers) {
  GIMM_CHECK(min_branch_px >= 2,
             "centerline_graph: min_branch_px must be >= 2, got " << min_branch_px);
  Image<std::uint8_t>& skel = buffers.skeleton;
  thin_mask(mask, skel, buffers);
  Image<std::uint8_t>& binary = buffers.binary;
  binary.resize(mask.rows(), mask.cols());
  for (std::size_t i = 0; i < mask.size(); ++i) binary.data()[i] = mask.data()[i] != T(0);
  CenterlineGraph2d g;
  g.rows = mask.rows();
  g.cols = mask.cols();
  const int rows = skel.rows(), cols = skel.cols();
  Image<std::uint8_t>&node = buffers.node, &used = buffers.used;
  node.assign(rows, cols, 0);
  used.assign(rows, cols, 0);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c)
      if (skel(r, c)) {
        const auto [count, transitions] = detail::ring_counts(skel, r, c);
        node(r, c) = count <= 1 || transitions >= 3;
      }
  // Walk from (r, c) into the neighbour (r1, c1) until a node or a dead end.
  const auto trace = [&](int r, int c, int r1, int c1) {
    std::vector<std::array<int, 2>> chain{{r, c}};
    int pr = r, pc = c;
    while (true) {
      chain.push_back({r1, c1});
      if (node(r1, c1)) break;
      used(r1, c1) = 1;
      int nr = -1, nc = -1;
      for (int pass = 0; pass < 2 && nr < 0; ++pass)  // 4-neighbours first
        for (int k = pass; k < 8; k += 2) {
          const int rr = r1 + detail::kRing[k][0], cc = c1 + detail::kRing[k][1];
          if (!detail::lit(skel, rr, cc) || (rr == pr && cc == pc)) continue;
          if (!node(rr, cc) && used(rr, cc)) continue;
          nr = rr;
          nc = cc;
          break;
        }
      if (nr < 0) break;
      pr = r1;
      pc = c1;
      r1 = nr;
      c1 = nc;
    }
    return chain;
  };
  const auto keep = [&](const std::vector<std::array<int, 2>>& chain) {
    if (static_cast<int>(chain.size()) < min_branch_px) return;
    Branch2d b;
    for (const auto& p : chain) {
      b.points.emplace_back(p[1], p[0]);
      b.radius_px.push_back(std::max(0.5, detail::distance_to_zero(binary, p[0], p[1]) - 0.5));
    }
    g.branches.push_back(std::move(b));
  };
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      if (!node(r, c)) continue;
      for (const auto& k : detail::kRing) {
        const int rr = r + k[0], cc = c + k[1];
        if (!detail::lit(skel, rr, cc) || used(rr, cc)) continue;
        // A node-to-node step is traced once, from the node that comes first in raster order.
        if (node(rr, cc) && (rr < r || (rr == r && cc < c))) continue;
        keep(trace(r, c, rr, cc));
      }
    }
  // Closed loops have no node: start anywhere on them.
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      if (!skel(r, c) || node(r, c) || used(r, c)) continue;
      used(r, c) = 1;
      for (const auto& k : detail::kRing) {
        const int rr = r + k[0], cc = c + k[1];
        if (detail::lit(skel, rr, cc) && !used(rr, cc)) {
          keep(trace(r, c, rr, cc));
          break;
        }
      }
    }
  return g;
}

template <class T>
CenterlineGraph2d centerline_graph(const Image<T>& mask, int min_branch_px = 5) {
  CenterlineBuffers buffers;
  return centerline_graph(mask, min_branch_px, buffers);
}

}  // namespace gimm
