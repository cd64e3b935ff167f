// Empty-space skipping (empty_space.hpp): which blocks are empty, and both projectors give the
// full walk's integrals when they skip them.
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <vector>

#include "gimm/core/rng.hpp"
#include "gimm/geometry/carm.hpp"
#include "gimm/render/drr.hpp"

using namespace gimm;

namespace {
// Sparse blobs in air: most blocks are empty, some are not, and blob edges straddle block
// faces. Values are strictly zero away from the blobs.
Volume<float> blobs_in_air(const VolumeGeometry& g, std::uint64_t seed) {
  Volume<float> v(g, 0.0f);
  Rng rng(seed);
  for (int b = 0; b < 6; ++b) {
    const Eigen::Vector3d c(rng.uniform(0, g.dims[0]), rng.uniform(0, g.dims[1]),
                            rng.uniform(0, g.dims[2]));
    const double r = rng.uniform(3.0, 12.0);
    for (int k = 0; k < g.dims[2]; ++k)
      for (int j = 0; j < g.dims[1]; ++j)
        for (int i = 0; i < g.dims[0]; ++i)
          if ((Eigen::Vector3d(i, j, k) - c).norm() < r)
            v(i, j, k) += static_cast<float>(rng.uniform(0.5, 1.5));
  }
  return v;
}
}  // namespace

TEST_CASE("Empty blocks: a block is empty exactly when its cells' voxels are all zero",
          "[render][trilinear][empty]") {
  constexpr int B = EmptyBlocks::kSize;
  VolumeGeometry g;
  g.dims = {2 * B + 4, 2 * B + 1, B + 3};  // 3 x 2 x 2 blocks of cells, partial on every axis
  Volume<float> v(g, 0.0f);
  v(B, 0, 0) = 1.0f;  // voxel B is the +1 neighbour of cell B - 1 (block 0) and in block 1
  const EmptyBlocks empty(v);
  CHECK_FALSE(empty.empty_at_cell(0, 0, 0));
  CHECK_FALSE(empty.empty_at_cell(B - 1, 0, 0));
  CHECK_FALSE(empty.empty_at_cell(B, 0, 0));
  CHECK(empty.empty_at_cell(2 * B, 0, 0));
  CHECK(empty.empty_at_cell(0, B, 0));
  CHECK(empty.empty_at_cell(0, 0, B));
  CHECK(empty.empty_fraction() == Approx(10.0 / 12.0));
  v(B, 0, 0) = 0.0f;
  v(2 * B + 3, 2 * B, B + 2) = -2.0f;  // the last voxel; negative values are not empty either
  const EmptyBlocks empty2(v);
  CHECK(empty2.empty_at_cell(0, 0, 0));
  CHECK_FALSE(empty2.empty_at_cell(2 * B + 2, 2 * B - 1, B + 1));
  CHECK(empty2.empty_fraction() == Approx(11.0 / 12.0));
}

namespace {
/// Random rays for the skipping tests: one in three axis-parallel, on block faces or half-way
/// between them (multiples of 8 in index space; blocks are 16 wide), on the voxel faces next to
/// them (+-0.5), or a hair off; the rest oblique from outside to a random point.
IndexRay random_ray(const Volume<float>& v, Rng& rng, int trial) {
  const VolumeGeometry& g = v.geometry();
  if (trial % 3 != 0) {
    const Eigen::Vector3d s(rng.uniform(-40, 40), rng.uniform(-40, 40), rng.uniform(-40, 40));
    const Eigen::Vector3d t = v.index_to_world(Eigen::Vector3d(
        rng.uniform(0, g.dims[0]), rng.uniform(0, g.dims[1]), rng.uniform(0, g.dims[2])));
    return to_index_ray(g, {s, (t - s).normalized()});
  }
  const int axis = trial % 9 / 3;
  IndexRay r;
  r.origin =
      glm::dvec3(8.0 * rng.uniform_int(0, 8), 8.0 * rng.uniform_int(0, 6), rng.uniform_int(0, 40));
  r.origin[axis] = -3.0;
  r.direction = glm::dvec3(0.0);
  r.direction[axis] = 1.0 / g.spacing[axis];
  const double offsets[4] = {0.0, 0.5, -0.5, 1e-13};
  r.origin[(axis + 1) % 3] += offsets[trial / 9 % 4];
  return r;
}

/// A small C-arm view of the world origin, 1.2 mm pixels at the isocentre.
Camerad carm_view(int rows, int cols, double primary, double secondary) {
  CArm carm;
  carm.rows = rows;
  carm.cols = cols;
  carm.pixel_mm = 1.6;
  carm.primary_deg = primary;
  carm.secondary_deg = secondary;
  return carm.camera();
}

VolumeGeometry sparse_grid() {
  VolumeGeometry g;
  g.dims = {70, 53, 41};
  g.spacing = {0.8, 0.6, 1.1};
  g.direction = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 0).normalized()).toRotationMatrix();
  return g;
}
}  // namespace

TEST_CASE("Trilinear: skipping empty blocks equals the full walk up to rounding",
          "[render][trilinear][empty]") {
  const Volume<float> v = blobs_in_air(sparse_grid(), 5);
  const EmptyBlocks empty(v);
  REQUIRE(empty.empty_fraction() > 0.3);
  REQUIRE(empty.empty_fraction() < 0.9);
  Rng rng(17);
  int non_zero = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    const IndexRay r = random_ray(v, rng, trial);
    const double step = rng.uniform(0.05, 2.0);
    const double full = trilinear_integral(v, r, step);
    const double skipped = trilinear_integral(v, r, step, 0.0, &empty);
    // Equal up to rounding: a sample may fall in the vectorised body of one run and in the
    // scalar tail of another, where the compiler may contract multiply-adds differently
    // (measured: 2e-16 relative at worst).
    REQUIRE(skipped == Approx(full).epsilon(1e-13).margin(1e-300));
    REQUIRE(skipped ==
            Approx(trilinear_integral_reference(v, r, step)).epsilon(1e-10).margin(1e-12));
    non_zero += full != 0.0;
  }
  CHECK(non_zero > 500);
}

TEST_CASE("Siddon: an integral split at any parameter adds up to the whole",
          "[render][siddon][empty]") {
  const VolumeGeometry g = sparse_grid();
  const Volume<float> v = blobs_in_air(g, 5);
  Rng rng(23);
  for (int trial = 0; trial < 1000; ++trial) {
    const IndexRay r = random_ray(v, rng, trial);
    const double whole = siddon_integral(v, r);
    const double cut = rng.uniform(0, 120);
    CHECK(siddon_integral(v, r, 0.0, cut) + siddon_integral(v, r, cut) ==
          Approx(whole).epsilon(1e-12).margin(1e-12));
    CHECK(siddon_integral(v, r, cut, cut) == 0.0);  // an empty interval
  }
}

TEST_CASE("Siddon: skipping empty blocks equals the full walk and the reference",
          "[render][siddon][empty]") {
  const VolumeGeometry g = sparse_grid();
  const Volume<float> v = blobs_in_air(g, 5);
  const EmptyBlocks empty(v);
  REQUIRE(empty.empty_fraction() > 0.3);
  Rng rng(19);
  int non_zero = 0, skipped_some = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    const IndexRay r = random_ray(v, rng, trial);
    const double full = siddon_integral(v, r);
    const double skipping = detail::siddon_integral_skipping(v, empty, r);
    REQUIRE(skipping == Approx(full).epsilon(1e-12).margin(1e-12));
    REQUIRE(skipping == Approx(siddon_integral_reference(v, r)).epsilon(1e-10).margin(1e-12));
    non_zero += full != 0.0;
    // The occupied intervals cover less than the whole chord when blocks were skipped.
    double s_enter, s_exit, covered = 0;
    if (clip_to_box({r.origin + 0.5, r.direction}, glm::dvec3(0.0),
                    glm::dvec3(g.dims[0], g.dims[1], g.dims[2]), 0.0, s_enter, s_exit)) {
      for_each_occupied_interval(empty, r, s_enter, s_exit,
                                 [&](double s0, double s1) { covered += s1 - s0; });
      skipped_some += covered < 0.9 * (s_exit - s_enter);
    }
  }
  CHECK(non_zero > 500);
  CHECK(skipped_some > 1000);
}

TEST_CASE("DRR: skipping empty space changes no pixel beyond rounding, for both projectors",
          "[render][drr][empty]") {
  VolumeGeometry g = sparse_grid();
  g.origin = -0.5 * Eigen::Vector3d(70 * 0.8, 53 * 0.6, 41 * 1.1);
  const Volume<float> v = blobs_in_air(g, 7);
  const Camerad camera = carm_view(48, 50, 25, 15);
  const EmptyBlocks empty(v);
  REQUIRE(empty.empty_fraction() >= detail::kSiddonSkipMinEmpty);  // both projectors skip
  for (const Projector projector : {Projector::siddon, Projector::trilinear}) {
    DrrOptions whole, skipping, prebuilt;
    whole.projector = skipping.projector = prebuilt.projector = projector;
    whole.skip_empty_space = false;
    prebuilt.empty_blocks = &empty;
    const Image<float> a = render_line_integrals(v, camera, whole);
    const Image<float> b = render_line_integrals(v, camera, skipping);
    const Image<float> c = render_line_integrals(v, camera, prebuilt);
    int non_zero = 0;
    for (std::size_t p = 0; p < a.size(); ++p) {
      REQUIRE(b.data()[p] == Approx(a.data()[p]).epsilon(1e-6).margin(1e-9));
      REQUIRE(c.data()[p] == b.data()[p]);
      non_zero += a.data()[p] != 0;
    }
    CHECK(non_zero > 100);
  }
  // A grid built for another volume is refused, also one with as many blocks (72 x 55 x 43
  // and 70 x 53 x 41 both make 5 x 4 x 3).
  VolumeGeometry other = sparse_grid();
  other.dims = {72, 55, 43};
  const EmptyBlocks wrong{Volume<float>(other, 0.0f)};
  DrrOptions bad;
  bad.empty_blocks = &wrong;
  for (const Projector projector : {Projector::siddon, Projector::trilinear}) {
    bad.projector = projector;
    CHECK_THROWS_WITH(render_line_integrals(v, camera, bad),
                      Catch::Contains("empty-block grid was built for another volume"));
  }
  const IndexRay ray{{-3.0, 20.0, 20.0}, {1.0, 0.0, 0.0}};
  CHECK_THROWS_WITH(trilinear_integral(v, ray, 0.5, 0.0, &wrong),
                    Catch::Contains("empty-block grid was built for another volume"));
}

TEST_CASE("Vessel mask: the skipping projections equal a full walk", "[render][drr][empty]") {
  VolumeGeometry g = sparse_grid();
  g.origin = -0.5 * Eigen::Vector3d(70 * 0.8, 53 * 0.6, 41 * 1.1);
  const Volume<float> blobs = blobs_in_air(g, 9);
  Volume<std::uint8_t> mask(g, 0);
  for (std::size_t n = 0; n < mask.size(); ++n) mask.data()[n] = blobs.data()[n] > 0 ? 3 : 0;
  const Camerad camera = carm_view(40, 40, -35, -10);
  const Volume<float> unit = unit_mask(mask);
  const EmptyBlocks empty(unit);
  REQUIRE(empty.empty_fraction() >= detail::kSiddonSkipMinEmpty);
  DrrOptions whole;
  whole.skip_empty_space = false;
  const Image<float> chord = render_line_integrals(unit, camera, whole);
  const Image<std::uint8_t> a = project_mask(mask, camera);
  const Image<std::uint8_t> b = project_unit_mask(unit, camera, 1e-6, &empty);
  int on = 0;
  for (std::size_t p = 0; p < a.size(); ++p) {
    REQUIRE(a.data()[p] == (chord.data()[p] >= 1e-6));
    REQUIRE(b.data()[p] == a.data()[p]);
    on += a.data()[p];
  }
  CHECK(on > 50);
  CHECK(on < static_cast<int>(a.size()));
}
