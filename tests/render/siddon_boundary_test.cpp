// The exact traversal on rays that touch the grid's boundary on voxel faces, edges and corners
// (boundary_rays.hpp): every exact path (Jacobs alone and paired, the empty-space skipping walk,
// the DRR renderer) gives the sorted-crossings reference (within the range of right answers for
// a ray that round-off leaves on a face) and never reads outside the grid.
// The suite also runs under AddressSanitizer (test render_asan), which turns such a read into a
// failure; without it an out-of-grid read of a neighbouring heap word passes silently.
#include <catch2/catch.hpp>

#include "boundary_rays.hpp"
#include "gimm/geometry/carm.hpp"
#include "gimm/render/drr.hpp"

using namespace gimm;

namespace {

Volume<float> random_volume(const VolumeGeometry& g, Rng& rng) {
  Volume<float> v(g);
  for (auto& x : v.storage()) x = static_cast<float>(rng.uniform(0.5, 1.5));
  return v;
}

/// Odd and even sizes, a single voxel, and one-voxel-thin slabs on each axis.
const Eigen::Vector3i kSizes[] = {{1, 1, 1}, {2, 3, 4}, {5, 5, 5}, {8, 3, 7},
                                  {6, 6, 6}, {1, 4, 3}, {4, 1, 3}, {3, 4, 1}};

/// Every exact path on `r` lies within the range of right answers (siddon_integral_bounds),
/// with a relative tolerance for the summation order.
void require_exact(const Volume<float>& v, const IndexRay& r) {
  const auto [lo, hi] = test::siddon_integral_bounds(v, r);
  const double tolerance = 1e-10 * hi + 1e-12;
  INFO("ray origin (" << r.origin.x << ", " << r.origin.y << ", " << r.origin.z << ") direction ("
                      << r.direction.x << ", " << r.direction.y << ", " << r.direction.z
                      << "), right answers [" << lo << ", " << hi << "]");
  // The ray alone, and in either slot of the two-ray interleave.
  double first = 0, second = 0, unused = 0;
  const IndexRay other{{-5, -4, -3}, {0.5, 0.6, 0.7}};
  siddon_integral_pair(v, r, other, first, unused);
  siddon_integral_pair(v, other, r, unused, second);
  for (const double got : {siddon_integral(v, r), first, second}) {
    REQUIRE(got >= lo - tolerance);
    REQUIRE(got <= hi + tolerance);
  }
}

}  // namespace

TEST_CASE("Siddon boundary: faces, edges and corners of the grid, in index space",
          "[render][siddon][boundary]") {
  Rng rng(20);
  for (const auto& dims : kSizes) {
    VolumeGeometry g;
    g.dims = {dims[0], dims[1], dims[2]};
    const Volume<float> values = random_volume(g, rng), ones(g, 1.0f);
    for (int trial = 0; trial < 3000; ++trial) {
      const IndexRay r = test::fragile_ray(rng, dims);
      require_exact(values, r);
      // A volume of ones integrates to the chord, computed slab by slab.
      REQUIRE(siddon_integral(ones, r) ==
              Approx(test::index_box_chord(r, dims)).epsilon(1e-10).margin(1e-12));
    }
  }
}

TEST_CASE("Siddon boundary: the same rays through scanner geometries (round-off at edges)",
          "[render][siddon][boundary]") {
  Rng rng(21);
  for (int which = 0; which < 3; ++which)
    for (const auto& dims : kSizes) {
      const VolumeGeometry g = test::scanner_geometry(which, dims);
      const Volume<float> values = random_volume(g, rng);
      for (int trial = 0; trial < 2000; ++trial)
        require_exact(values, test::through_world(g, test::fragile_ray(rng, dims)));
    }
}

TEST_CASE("Siddon boundary: axis-parallel rays in the boundary planes follow the [i, i+1) rule",
          "[render][siddon][boundary]") {
  VolumeGeometry g;
  g.dims = {3, 4, 5};
  Rng rng(22);
  const Volume<float> v = random_volume(g, rng);
  // Along z in the plane x = -0.5 (the grid's low x face) and x = 2.5 (its high x face), and on
  // the edges with y = -0.5 and y = 3.5: a low face is the [i, i+1) side of voxel 0; a high
  // face has no voxel on that side, so the ray misses (the grid is half-open, and a grid that
  // adjoins it there, an axial pad, takes the ray instead: axial_pad_test.cpp).
  for (const double x : {-0.5, 2.5})
    for (const double y : {-0.5, 1.2, 3.5}) {
      const IndexRay r{{x, y, -4.0}, {0.0, 0.0, 1.0}};
      const bool on_high_face = x > 0 || y > 3;
      const int i = x < 0 ? 0 : 2, j = y < 0 ? 0 : 1;
      double expected = 0;
      if (!on_high_face)
        for (int k = 0; k < 5; ++k) expected += v(i, j, k);
      CHECK(siddon_integral(v, r) == Approx(expected).epsilon(1e-12));
      CHECK(siddon_integral_reference(v, r) == Approx(expected).epsilon(1e-12));
    }
}

TEST_CASE("Siddon boundary: the skipping walk on fragile rays equals the reference",
          "[render][siddon][boundary][empty]") {
  Rng rng(23);
  constexpr int B = EmptyBlocks::kSize;
  // Several blocks per axis, the last one partial; values only in a few blocks, one of them in
  // a corner of the grid, so occupied intervals end on block faces and on the grid boundary.
  for (const Eigen::Vector3i& dims :
       {Eigen::Vector3i(2 * B + 3, B + 5, 2 * B), Eigen::Vector3i(3 * B, 2 * B + 1, B + 1)}) {
    for (int which = 0; which < 3; ++which) {
      const VolumeGeometry g = test::scanner_geometry(which, dims);
      Volume<float> v(g, 0.0f);
      for (int k = 0; k < dims[2]; ++k)
        for (int j = 0; j < dims[1]; ++j)
          for (int i = 0; i < dims[0]; ++i) {
            const bool corner_block = i >= dims[0] - 4 && j >= dims[1] - 4 && k < 4;
            const bool inner_block = i >= B && i < 2 * B && j < B && k >= B / 2;
            if (corner_block || inner_block) v(i, j, k) = static_cast<float>(rng.uniform(0.5, 2));
          }
      const EmptyBlocks empty(v);
      REQUIRE(empty.empty_fraction() > 0.3);
      for (int trial = 0; trial < 2000; ++trial) {
        IndexRay r = test::fragile_ray(rng, dims);
        if (trial % 2) r = test::through_world(g, r);
        const auto [lo, hi] = test::siddon_integral_bounds(v, r);
        const double skipping = detail::siddon_integral_skipping(v, empty, r);
        REQUIRE(skipping >= lo - 1e-10 * hi - 1e-12);
        REQUIRE(skipping <= hi + 1e-10 * hi + 1e-12);
        require_exact(v, r);
      }
    }
  }
}

TEST_CASE("Siddon boundary: AP DRRs of a slab with the isocentre at its centre (the crash case)",
          "[render][siddon][boundary][drr]") {
  // The reported crash: a chest CT's grid (0.9765625 mm in-plane, 2 mm slices, stored RAS
  // first), gimm-drr's defaults (AP, isocentre at the volume centre): detector rays pass through
  // voxel edges where they leave the grid. Smaller grids of the same geometry, odd and even.
  for (const Eigen::Vector3i& dims : {Eigen::Vector3i(64, 64, 20), Eigen::Vector3i(63, 65, 21)}) {
    const VolumeGeometry g = test::scanner_geometry(0, dims);
    for (const bool mostly_empty : {false, true}) {
      Volume<float> mu(g, 0.0f);
      for (int k = 0; k < dims[2]; ++k)
        for (int j = mostly_empty ? 40 : 17; j < dims[1] - 3; ++j)
          for (int i = 0; i < (mostly_empty ? 9 : dims[0]); ++i) mu(i, j, k) = 0.02f;
      CArm carm;
      carm.rows = carm.cols = 256;
      carm.pixel_mm = 0.4;
      carm.isocenter =
          mu.index_to_world(Eigen::Vector3d(dims[0] - 1, dims[1] - 1, dims[2] - 1) / 2);
      const Camerad camera = carm.camera();
      const IndexSpace to_index(g);
      const RayGenerator rays(camera);
      for (const bool skip : {false, true}) {
        DrrOptions options;
        options.skip_empty_space = skip;
        const Image<float> drr = render_line_integrals(mu, camera, options);
        for (int v = 0; v < camera.rows(); ++v)
          for (int u = 0; u < camera.cols(); ++u) {
            const auto [lo, hi] = test::siddon_integral_bounds(mu, to_index(rays(u, v)));
            REQUIRE(drr(v, u) >= lo * (1 - 1e-6) - 1e-7);  // float image: relative 1e-6
            REQUIRE(drr(v, u) <= hi * (1 + 1e-6) + 1e-7);
          }
      }
    }
  }
}

TEST_CASE("Siddon boundary: a zero direction is a miss, not an unbounded chord",
          "[render][siddon][boundary]") {
  VolumeGeometry g;
  g.dims = {3, 3, 3};
  const Volume<float> v(g, 1.0f);
  for (const glm::dvec3 origin : {glm::dvec3(1, 1, 1), glm::dvec3(-0.5), glm::dvec3(-4, 0, 0)}) {
    const IndexRay r{origin, glm::dvec3(0.0)};
    CHECK(siddon_integral(v, r) == 0.0);
    CHECK(siddon_integral_reference(v, r) == 0.0);
  }
}
