// The whole-chest phantom (PhantomSize::chest, anatomy/chest.hpp): the same heart and tree as
// the cardiac crop, the skeleton and lungs where anatomy puts them, bones that the
// angiography recipe calls bone and a blood pool it calls blood, and a body inside its grid.
#include <catch2/catch.hpp>
#include <cmath>

#include "gimm/anatomy/attenuation.hpp"
#include "gimm/anatomy/chest.hpp"
#include "gimm/anatomy/phantom.hpp"

using namespace gimm;

namespace {

Phantom phantom(std::uint64_t seed, PhantomSize size) {
  PhantomOptions o;
  o.seed = seed;
  o.size = size;
  o.noise_hu = 0;  // exact tissue values identify the structures
  return make_phantom(o);
}

double hu_at(const Phantom& p, double x, double y, double z) {
  return p.hu.sample_world(Eigen::Vector3d(x, y, z));
}

}  // namespace

TEST_CASE("Chest: the heart and coronary tree are those of the cardiac crop", "[anatomy][chest]") {
  const Phantom crop = phantom(4, PhantomSize::small), chest = phantom(4, PhantomSize::chest);
  REQUIRE(crop.centerlines.branches.size() == chest.centerlines.branches.size());
  for (std::size_t b = 0; b < crop.centerlines.branches.size(); ++b) {
    CHECK(crop.centerlines.branches[b].points == chest.centerlines.branches[b].points);
    CHECK(crop.centerlines.branches[b].radii == chest.centerlines.branches[b].radii);
  }
  CHECK(crop.anatomy.lumen_hu == chest.anatomy.lumen_hu);
  CHECK(std::isnan(crop.anatomy.t1_top_z));
  CHECK(std::isfinite(chest.anatomy.t1_top_z));
}

TEST_CASE("Chest: the body lies inside its grid, with air all round", "[anatomy][chest]") {
  for (const std::uint64_t seed : {0u, 9u}) {
    const Phantom p = phantom(seed, PhantomSize::chest);
    // The outermost voxel columns and rows of every slice are air: no crop of the body.
    const int nx = p.hu.nx(), ny = p.hu.ny(), nz = p.hu.nz();
    std::int64_t body_on_edge = 0;
    for (int k = 0; k < nz; ++k) {
      for (int i = 0; i < nx; ++i)
        body_on_edge += (p.hu(i, 0, k) > -1000) + (p.hu(i, ny - 1, k) > -1000);
      for (int j = 0; j < ny; ++j)
        body_on_edge += (p.hu(0, j, k) > -1000) + (p.hu(nx - 1, j, k) > -1000);
    }
    INFO("seed " << seed);
    CHECK(body_on_edge == 0);
    // 380 mm head to foot, 1.6 x 1.6 x 2 mm voxels.
    CHECK(nz * p.hu.geometry().spacing.z() == Approx(380));
  }
}

TEST_CASE("Chest: skeleton, lungs and diaphragm sit where anatomy puts them", "[anatomy][chest]") {
  const Phantom p = phantom(2, PhantomSize::chest);
  const auto& A = p.anatomy;
  const double cx = A.body_axis.x(), cy = A.body_axis.y();
  const detail::TissueHu tissue(Rng(2).fork(0x7155e));
  // The right dome (the liver's) is higher than the left (the heart's); T1 far above both.
  CHECK(A.right_dome_z > A.left_dome_z + 5);
  CHECK(A.t1_top_z > A.right_dome_z + 150);
  // Lung above the left dome, no lung below it (mid-clavicular line, 70 mm left).
  CHECK(hu_at(p, cx + 70, cy - 5, A.left_dome_z + 20) < -700);
  CHECK(hu_at(p, cx + 70, cy - 5, A.left_dome_z - 70) > -200);  // below the gastric bubble
  // Liver below the right dome.
  CHECK(hu_at(p, cx - 40, cy, A.right_dome_z - 30) == Approx(65));
  // Vertebral bodies behind the heart, with discs: along the spine's axis the HU alternates
  // between bone (>= trabecular) and disc (90) once per 27 mm level.
  int bone = 0, disc = 0, switches = 0;
  bool was_bone = false;
  for (double z = A.t1_top_z - 20; z > A.t1_top_z - 20 - 10 * ChestModel::kLevelMm; z -= 1) {
    const double h = hu_at(p, cx, cy + 118 - 30 - 16, z);
    const bool is_bone = h >= tissue.trabecular - 1;
    bone += is_bone;
    disc += std::abs(h - 90) < 1;
    switches += is_bone != was_bone;
    was_bone = is_bone;
  }
  CHECK(bone > 150);
  CHECK(disc > 25);
  CHECK(switches >= 18);  // about two per level over ten levels
  // A rib runs down from its posterior end: followed along the wall on the patient's left,
  // from near the spine (theta 1.2 rad) to the side (0.1 rad), its centre drops 10+ mm.
  auto rib_centre = [&](double theta, double z_lo, double z_hi) {
    const double x = cx + 0.86 * 165 * std::cos(theta), y = cy + 0.86 * 118 * std::sin(theta);
    double sum = 0;
    int n = 0;
    for (double z = z_lo; z <= z_hi; z += 0.25)
      if (hu_at(p, x, y, z) >= tissue.marrow - 1) sum += z, ++n;
    return n ? sum / n : std::nan("");
  };
  // The third rib's posterior end: the first rib centre found below T1 - 60 mm.
  double z = std::nan("");
  for (double top = A.t1_top_z - 60; std::isnan(z) && top > A.t1_top_z - 120; top -= 4)
    z = rib_centre(1.2, top - 4, top);
  REQUIRE(std::isfinite(z));
  z = rib_centre(1.2, z - 8, z + 8);  // the whole rib's section
  const double posterior = z;
  for (double theta = 1.18; theta >= 0.1; theta -= 0.02) {
    const double next = rib_centre(theta, z - 4, z + 4);
    REQUIRE(std::isfinite(next));  // one rib, unbroken
    z = next;
  }
  INFO("rib centre: posterior " << posterior << " mm, lateral " << z << " mm");
  CHECK(z < posterior - 10);
}

TEST_CASE("Chest: the recipe calls its bones bone and its blood pool blood",
          "[anatomy][chest][recipe]") {
  for (const std::uint64_t seed : {1u, 6u}) {
    const Phantom p = phantom(seed, PhantomSize::chest);
    const detail::TissueHu tissue(Rng(seed).fork(0x7155e));
    const Volume<float> hu = volume_cast<float>(p.hu);
    const DenseTissue d = classify_dense_tissue(hu, ContrastRecipe{});
    std::int64_t lumen = 0, lumen_blood = 0, cortex = 0, cortex_bone = 0, svc = 0, svc_blood = 0;
    const double lumen_hu = std::round(p.anatomy.lumen_hu);
    for (std::size_t v = 0; v < hu.size(); ++v) {
      const double h = hu.data()[v];
      const auto c = static_cast<ContrastRecipe::Dense>(d.classes.data()[v]);
      if (h == lumen_hu) lumen += 1, lumen_blood += c == ContrastRecipe::Dense::blood;
      if (h == std::round(tissue.cortex))
        cortex += 1, cortex_bone += c == ContrastRecipe::Dense::bone;
      if (h == std::round(tissue.svc)) svc += 1, svc_blood += c == ContrastRecipe::Dense::blood;
    }
    INFO("seed " << seed << ": blood pool " << lumen_blood << "/" << lumen << ", cortex "
                 << cortex_bone << "/" << cortex << ", SVC " << svc_blood << "/" << svc);
    REQUIRE(lumen > 10000);
    REQUIRE(cortex > 10000);
    // Fused (the aorta touching a vertebra), one class would take both: it does not.
    CHECK(lumen_blood >= 0.99 * lumen);
    CHECK(cortex_bone >= 0.99 * cortex);
    CHECK(svc_blood == svc);
  }
}

TEST_CASE("Chest: value noise is smooth, bounded and the same at a point", "[anatomy][chest]") {
  double lo = 1, hi = -1, max_step = 0;
  for (int n = 0; n < 2000; ++n) {
    const Eigen::Vector3d p(0.37 * n, -0.11 * n, 5 + 0.05 * n);
    const double v = detail::value_noise(p, 11.0, 42);
    CHECK(v == detail::value_noise(p, 11.0, 42));
    lo = std::min(lo, v), hi = std::max(hi, v);
    if (n)
      max_step = std::max(
          max_step,
          std::abs(v - detail::value_noise(
                           Eigen::Vector3d(0.37 * (n - 1), -0.11 * (n - 1), 5 + 0.05 * (n - 1)),
                           11.0, 42)));
  }
  CHECK(lo >= -1);
  CHECK(hi <= 1);
  CHECK(hi - lo > 0.8);    // it varies
  CHECK(max_step < 0.15);  // smoothly: 0.39 mm steps on an 11 mm lattice
}
