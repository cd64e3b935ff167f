#pragma once
/// The exact Euclidean distance transform (Felzenszwalb & Huttenlocher, separable): the distance
/// from each voxel centre to the nearest background voxel centre, in mm.
/// Used for vessel radii of the 3D centerlines (anatomy/skeleton.hpp).
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

#include "gimm/core/huge_pages.hpp"
#include "gimm/core/volume.hpp"

namespace gimm {

namespace detail {

/// 1D squared distance transform: d[q] = min_p (q - p)^2 h^2 + f[p], where f is 0 on features
/// and +inf elsewhere (or a previous pass's squared distances).
inline void edt_1d(const double* f, double* d, int n, double h, std::vector<int>& v,
                   std::vector<double>& z) {
  v.assign(n, 0);
  z.assign(n + 1, 0);
  const double inf = std::numeric_limits<double>::infinity();
  auto meet = [&](int p, int q) {  // where the parabolas rooted at p and q intersect
    return ((f[q] + q * h * q * h) - (f[p] + p * h * p * h)) / (2 * h * (q - p));
  };
  int k = -1;
  for (int q = 0; q < n; ++q) {
    if (!std::isfinite(f[q])) continue;
    double s = -inf;
    while (k >= 0 && (s = meet(v[k], q)) <= z[k]) --k;
    ++k;
    v[k] = q;
    z[k] = k == 0 ? -inf : s;
    z[k + 1] = inf;
  }
  if (k < 0) {
    std::fill(d, d + n, inf);
    return;
  }
  k = 0;
  for (int q = 0; q < n; ++q) {
    while (z[k + 1] < q * h) ++k;
    const double dq = (q - v[k]) * h;
    d[q] = dq * dq + f[v[k]];
  }
}

}  // namespace detail

/// Euclidean distance (mm) from each voxel centre to the nearest voxel centre where
/// `mask` is zero; 0 on background. +inf everywhere if the mask has no background.
template <class T>
Volume<float> distance_to_background(const Volume<T>& mask) {
  const int n[3] = {mask.nx(), mask.ny(), mask.nz()};
  std::vector<double> g;
  resize_huge(g, mask.size());
  for (std::size_t i = 0; i < g.size(); ++i)
    g[i] = mask.data()[i] != T(0) ? std::numeric_limits<double>::infinity() : 0.0;
  const std::size_t stride[3] = {1, static_cast<std::size_t>(n[0]),
                                 static_cast<std::size_t>(n[0]) * n[1]};
  std::vector<double> f, d;
  std::vector<int> v;
  std::vector<double> z;
  for (int axis = 0; axis < 3; ++axis) {
    const int len = n[axis];
    f.resize(len);
    d.resize(len);
    const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
    for (int p = 0; p < n[a1]; ++p)
      for (int q = 0; q < n[a2]; ++q) {
        const std::size_t base = p * stride[a1] + q * stride[a2];
        for (int i = 0; i < len; ++i) f[i] = g[base + i * stride[axis]];
        detail::edt_1d(f.data(), d.data(), len, mask.spacing()[axis], v, z);
        for (int i = 0; i < len; ++i) g[base + i * stride[axis]] = d[i];
      }
  }
  Volume<float> out(mask.geometry());
  for (std::size_t i = 0; i < g.size(); ++i) out.data()[i] = static_cast<float>(std::sqrt(g[i]));
  return out;
}

}  // namespace gimm
