// siddon_mask_hits (render/siddon.hpp): the first vessel hit and the number of separate passages
// of a ray through a binary mask, against a slow reference built on Siddon's sorted crossings
// (each segment's voxel from its midpoint), on seeded random rays through random sparse masks,
// on hand-made cases whose answer is known, and on the fragile boundary rays
// (boundary_rays.hpp). Also in the AddressSanitizer binary (test render_asan): the walk reads
// the mask voxel by voxel, so an out-of-grid read fails there.
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <vector>

#include "boundary_rays.hpp"
#include "gimm/core/rng.hpp"
#include "gimm/render/siddon.hpp"

using namespace gimm;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// The slow reference: Siddon's sorted crossings from s_min, each positive-length segment's voxel
/// found from its midpoint, the segments cut at s_max; a passage opens on the first nonzero
/// segment after a zero one (or the start). Zero-length segments are skipped (they neither open
/// nor split a passage). Shares only detail::sorted_crossings with the code under test.
template <class T>
MaskRayHits reference_hits(const Volume<T>& mask, const IndexRay& ray, double s_min = 0.0,
                           double s_max = kInf) {
  const glm::dvec3 o = ray.origin + 0.5;
  const glm::dvec3& d = ray.direction;
  const int n[3] = {mask.nx(), mask.ny(), mask.nz()};
  const std::vector<double> s_all = detail::sorted_crossings(mask, ray, s_min);
  MaskRayHits out;
  bool inside = false;
  for (std::size_t m = 0; m + 1 < s_all.size(); ++m) {
    const double a = s_all[m], b = std::min(s_all[m + 1], s_max);
    if (!(a < s_max)) break;
    if (!(b > a)) continue;
    const double mid = 0.5 * (a + b);
    int idx[3];
    for (int axis = 0; axis < 3; ++axis)
      idx[axis] = std::clamp(static_cast<int>(std::floor(o[axis] + mid * d[axis])), 0, n[axis] - 1);
    const bool on = mask(idx[0], idx[1], idx[2]) != T(0);
    if (on && !inside) {
      if (out.passages == 0) out.first_hit_mm = a;
      ++out.passages;
    }
    inside = on;
  }
  return out;
}

/// A second, cruder reference for the hand-made cases: dense sampling every `step` mm.
template <class T>
MaskRayHits sampled_hits(const Volume<T>& mask, const IndexRay& ray, double s_max, double step) {
  MaskRayHits out;
  bool inside = false;
  for (double s = 0; s <= s_max; s += step) {
    const glm::dvec3 p = ray.origin + 0.5 + s * ray.direction;
    const int i = static_cast<int>(std::floor(p.x)), j = static_cast<int>(std::floor(p.y)),
              k = static_cast<int>(std::floor(p.z));
    const bool on = mask.contains(i, j, k) && mask(i, j, k) != T(0);
    if (on && !inside) {
      if (out.passages == 0) out.first_hit_mm = s;
      ++out.passages;
    }
    inside = on;
  }
  return out;
}

void require_same(const MaskRayHits& got, const MaskRayHits& expected) {
  REQUIRE(got.passages == expected.passages);
  if (std::isinf(expected.first_hit_mm)) {
    REQUIRE(std::isinf(got.first_hit_mm));
  } else {
    // Jacobs accumulates its crossings (next += delta); the reference divides afresh.
    REQUIRE(got.first_hit_mm == Approx(expected.first_hit_mm).epsilon(1e-10).margin(1e-9));
  }
}

/// A sparse random mask (about `fill` of the voxels on) on a rotated, anisotropic grid.
template <class T>
Volume<T> random_mask(Rng& rng, double fill) {
  VolumeGeometry g;
  g.dims = {static_cast<int>(rng.uniform_int(1, 14)), static_cast<int>(rng.uniform_int(1, 14)),
            static_cast<int>(rng.uniform_int(1, 14))};
  g.spacing = Eigen::Vector3d(rng.uniform(0.3, 2.0), rng.uniform(0.3, 2.0), rng.uniform(0.3, 2.0));
  g.origin = Eigen::Vector3d(rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-5, 5));
  g.direction =
      Eigen::AngleAxisd(rng.uniform(-3, 3),
                        Eigen::Vector3d(rng.uniform(-1, 1), rng.uniform(-1, 1), 1).normalized())
          .toRotationMatrix();
  Volume<T> m(g, T(0));
  for (auto& x : m.storage())
    if (rng.uniform(0, 1) < fill) x = static_cast<T>(rng.uniform_int(1, 9));
  return m;
}

/// A world ray from well outside (or, one time in four, inside) the grid through a random point
/// of it (or near it).
template <class T>
Ray<double> random_world_ray(const Volume<T>& m, Rng& rng) {
  const Eigen::Vector3d target = m.index_to_world(
      Eigen::Vector3d(rng.uniform(-1, m.nx()), rng.uniform(-1, m.ny()), rng.uniform(-1, m.nz())));
  const Eigen::Vector3d dir =
      Eigen::Vector3d(rng.normal(), rng.normal(), rng.normal()).normalized();
  const double back = rng.uniform(0, 4) < 1 ? rng.uniform(0, 3) : rng.uniform(20, 60);
  return {target - back * dir, dir};
}

/// 30 x 5 x 5 unit voxels at the world origin (voxel i spans x in [i - 0.5, i + 0.5]) with two
/// blobs on the row j = k = 2: x voxels 5..8 and 15..18.
Volume<std::uint8_t> two_blobs() {
  VolumeGeometry g;
  g.dims = {30, 5, 5};
  Volume<std::uint8_t> m(g, 0);
  for (int i = 5; i <= 8; ++i) m(i, 2, 2) = 1;
  for (int i = 15; i <= 18; ++i) m(i, 2, 2) = 1;
  return m;
}

IndexRay along_x(const VolumeGeometry& g, const Eigen::Vector3d& from, double sign = 1) {
  return to_index_ray(g, Ray<double>{from, Eigen::Vector3d(sign, 0, 0)});
}

}  // namespace

TEST_CASE(
    "Mask hits: random rays through random sparse masks equal the sorted-crossing "
    "reference",
    "[render][siddon][mask_hits]") {
  Rng rng(1234);
  int with_two = 0, hit = 0;
  for (int volume = 0; volume < 60; ++volume) {
    const auto mask = random_mask<std::uint8_t>(rng, rng.uniform(0.05, 0.3));
    const IndexSpace to_index(mask.geometry());
    for (int trial = 0; trial < 200; ++trial) {
      const Ray<double> world = random_world_ray(mask, rng);
      const IndexRay ray = to_index(world);
      INFO("volume " << volume << " trial " << trial);
      // The whole ray, then a window [s_min, s_max] of it (a passage open at s_max counts; one
      // open at s_min starts there).
      const MaskRayHits whole = siddon_mask_hits(mask, ray);
      require_same(whole, reference_hits(mask, ray));
      const double s_min = rng.uniform(0, 40), s_max = s_min + rng.uniform(0, 40);
      require_same(siddon_mask_hits(mask, ray, s_min, s_max),
                   reference_hits(mask, ray, s_min, s_max));
      if (whole.passages > 0) {
        ++hit;
        REQUIRE(whole.first_hit_mm >= 0);
      }
      with_two += whole.passages >= 2;
    }
  }
  // The rays exercise what is tested: most hit something, many cross two runs or more.
  CHECK(hit > 4000);
  CHECK(with_two > 1500);
}

TEST_CASE("Mask hits: every voxel type the traversal takes", "[render][siddon][mask_hits]") {
  Rng rng(99);
  for (int volume = 0; volume < 10; ++volume) {
    const auto u8 = random_mask<std::uint8_t>(rng, 0.2);
    const Volume<float> f = volume_cast<float>(u8);
    const Volume<std::int16_t> i16 = volume_cast<std::int16_t>(u8);
    for (int trial = 0; trial < 100; ++trial) {
      const IndexRay ray = to_index_ray(u8.geometry(), random_world_ray(u8, rng));
      const MaskRayHits expected = reference_hits(u8, ray);
      require_same(siddon_mask_hits(u8, ray), expected);
      require_same(siddon_mask_hits(f, ray), expected);
      require_same(siddon_mask_hits(i16, ray), expected);
    }
  }
}

TEST_CASE("Mask hits: two blobs, a miss, and a window that ends between them",
          "[render][siddon][mask_hits]") {
  const auto m = two_blobs();
  const VolumeGeometry& g = m.geometry();
  // Along +x from x = -10, off the voxel planes: blob 1 starts at x = 4.5 (s = 14.5), ends at
  // 8.5 (s = 18.5); blob 2 spans x = 14.5 .. 18.5 (s = 24.5 .. 28.5).
  const IndexRay ray = along_x(g, {-10, 2.1, 1.9});
  MaskRayHits h = siddon_mask_hits(m, ray);
  CHECK(h.passages == 2);
  CHECK(h.first_hit_mm == Approx(14.5).margin(1e-12));
  require_same(h, reference_hits(m, ray));
  const MaskRayHits sampled = sampled_hits(m, ray, 60, 0.01);
  CHECK(sampled.passages == 2);
  CHECK(h.first_hit_mm == Approx(sampled.first_hit_mm).margin(0.011));

  // The same row walked backwards: blob 2 comes first, entered at x = 18.5.
  h = siddon_mask_hits(m, along_x(g, {40, 2.1, 1.9}, -1));
  CHECK(h.passages == 2);
  CHECK(h.first_hit_mm == Approx(21.5).margin(1e-12));

  // A ray beside the blobs (row k = 4) and a ray that misses the grid: inf and 0.
  for (const Eigen::Vector3d& from : {Eigen::Vector3d(-10, 2.1, 3.9), Eigen::Vector3d(-10, 2, 9)}) {
    h = siddon_mask_hits(m, along_x(g, from));
    CHECK(h.passages == 0);
    CHECK(std::isinf(h.first_hit_mm));
    CHECK(h.first_hit_mm > 0);
  }

  // s_max before blob 2: one passage. Inside blob 2 (s = 26): two, the second cut short.
  h = siddon_mask_hits(m, ray, 0.0, 20.0);
  CHECK(h.passages == 1);
  CHECK(h.first_hit_mm == Approx(14.5).margin(1e-12));
  CHECK(siddon_mask_hits(m, ray, 0.0, 26.0).passages == 2);
  // s_max exactly where blob 2 begins: no positive length of it, so one passage.
  CHECK(siddon_mask_hits(m, ray, 0.0, 24.5).passages == 1);
  // s_min inside blob 1: the first passage starts at s_min.
  h = siddon_mask_hits(m, ray, 16.0);
  CHECK(h.passages == 2);
  CHECK(h.first_hit_mm == Approx(16.0).margin(1e-12));
  // s_min past both blobs, or a window of zero length: nothing.
  CHECK(siddon_mask_hits(m, ray, 29.0).passages == 0);
  CHECK(siddon_mask_hits(m, ray, 16.0, 16.0).passages == 0);
}

TEST_CASE("Mask hits: runs that touch merge, corner steps neither open nor split a passage",
          "[render][siddon][mask_hits]") {
  // Adjacent runs of different nonzero values are one passage (nonzero = inside).
  auto m = two_blobs();
  for (int i = 9; i <= 14; ++i) m(i, 2, 2) = 7;
  CHECK(siddon_mask_hits(m, along_x(m.geometry(), {-10, 2.1, 1.9})).passages == 1);

  // A diagonal staircase of voxels (5,5), (6,6), (7,7) in the plane k = 1. The ray through their
  // centres passes exactly through the shared corners, where the x and y crossings coincide: the
  // walk then takes a zero-length step into (6,5) or (5,6), which are empty. One passage.
  VolumeGeometry g;
  g.dims = {12, 12, 3};
  Volume<std::uint8_t> stairs(g, 0);
  for (int n = 5; n <= 7; ++n) stairs(n, n, 1) = 1;
  const IndexRay diagonal{{0, 0, 1}, glm::dvec3(1, 1, 0) / std::sqrt(2.0)};
  MaskRayHits h = siddon_mask_hits(stairs, diagonal);
  CHECK(h.passages == 1);
  CHECK(h.first_hit_mm == Approx(4.5 * std::sqrt(2.0)).epsilon(1e-12));
  require_same(h, reference_hits(stairs, diagonal));
  // Without the middle voxel the corner touch between (5,5) and (7,7) is empty: two passages.
  stairs(6, 6, 1) = 0;
  CHECK(siddon_mask_hits(stairs, diagonal).passages == 2);
}

TEST_CASE(
    "Mask hits: fragile boundary rays stay in the grid and count one passage in a full "
    "mask",
    "[render][siddon][mask_hits][boundary]") {
  // A mask of ones: any ray with a positive chord through the grid is one passage entered where
  // it enters the grid; a ray with none is a miss. Under ASan an out-of-grid read fails.
  Rng rng(77);
  for (const Eigen::Vector3i& dims : {Eigen::Vector3i(1, 1, 1), Eigen::Vector3i(2, 3, 4),
                                      Eigen::Vector3i(5, 5, 5), Eigen::Vector3i(4, 1, 3)}) {
    VolumeGeometry g;
    g.dims = {dims[0], dims[1], dims[2]};
    const Volume<std::uint8_t> ones(g, 1);
    const Volume<std::uint8_t> sparse = [&] {
      Volume<std::uint8_t> v(g, 0);
      for (auto& x : v.storage()) x = rng.uniform(0, 1) < 0.4;
      return v;
    }();
    for (int trial = 0; trial < 2000; ++trial) {
      const IndexRay r = test::fragile_ray(rng, dims);
      const double chord = test::index_box_chord(r, dims);
      const MaskRayHits h = siddon_mask_hits(ones, r);
      INFO("ray origin (" << r.origin.x << ", " << r.origin.y << ", " << r.origin.z
                          << ") direction (" << r.direction.x << ", " << r.direction.y << ", "
                          << r.direction.z << "), chord " << chord);
      // (Within round-off of a zero chord either answer is right.)
      REQUIRE(h.passages <= 1);
      if (chord > 1e-9) REQUIRE(h.passages == 1);
      REQUIRE((h.passages == 0) == std::isinf(h.first_hit_mm));
      // A sparse mask on the same rays: bounded by the voxels crossed, and walked safely.
      const MaskRayHits s = siddon_mask_hits(sparse, r);
      REQUIRE(s.passages <= dims.sum());
      REQUIRE((s.passages == 0) == std::isinf(s.first_hit_mm));
    }
  }
}
